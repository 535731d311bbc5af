"""The runner of the README's and its docs pages' shell and Python blocks
(.ci/readme_examples.py): the blocks run as written, in order, in one folder that starts
empty (a later block finds what an earlier one wrote, as for a reader), a failing line
fails it, a block that needs an extra is listed, not run. CI runs it over every page
against the installed wheel (.ci/wheel_smoke.sh); `python .ci/readme_examples.py` runs it
here."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / ".ci" / "readme_examples.py"


def _runner():
    spec = importlib.util.spec_from_file_location("readme_examples", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _run(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=timeout
    )


def test_the_readme_links_docs_pages_whose_blocks_are_found():
    runner = _runner()
    pages = runner.pages(ROOT / "README.md")
    names = {p.relative_to(ROOT).as_posix() for p in pages}
    for page in ("reference", "conventions", "tracks", "sensors", "experiments", "speed"):
        assert f"docs/{page}.md" in names
    found = [b for page in pages for b in runner.blocks(page)]
    core = [b for b in found if not b.needs]
    assert any(b.kind == "shell" for b in core) and any(b.kind == "python" for b in core)
    assert any("gym.make(" in b.code for b in core)
    assert {"checkout", "train"} <= {n for b in found for n in b.needs}


def test_the_readme_is_short():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 300


def test_a_broken_python_block_fails_the_runner(tmp_path: Path):
    readme = tmp_path / "README.md"
    readme.write_text("# x\n\n```python\nimport tinyrace\nraise SystemExit(3)\n```\n")
    done = _run(str(readme))
    assert done.returncode == 1 and "README.md:3 (python): FAILED (exit 3" in done.stdout


def test_a_failing_shell_line_fails_the_runner_and_blocks_start_in_an_empty_folder(
    tmp_path: Path,
):
    readme = tmp_path / "README.md"
    readme.write_text(
        '```bash\ntest -z "$(ls -A)"\ntinyrace --version\n```\n\n'
        "```sh\nfalse\necho not reached\n```\n"
    )
    done = _run(str(readme))
    assert done.returncode == 1, done.stdout
    assert "README.md:1 (shell): ok" in done.stdout
    assert "README.md:6 (shell): FAILED (exit 1" in done.stdout
    assert "not reached" not in done.stdout


def test_the_blocks_share_one_folder_in_page_order(tmp_path: Path):
    """The README's quick start copies a track, a later block uses the copy: one folder."""
    readme = tmp_path / "README.md"
    readme.write_text(
        "```bash\necho copied > made.txt\n```\n\n"
        "```python\nfrom pathlib import Path\nassert Path('made.txt').read_text() == 'copied\\n'\n"
        "Path('second.txt').write_text('x')\n```\n\n"
        "```sh\ntest -f second.txt && test -f made.txt\n```\n"
    )
    done = _run(str(readme))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "3 blocks: 3 ran, 3 ok, 0 failed, 0 skipped" in done.stdout
    assert not (tmp_path / "made.txt").exists()  # the folder is a new one, not the page's


def test_blocks_that_need_an_extra_are_listed_not_run_unless_given(tmp_path: Path):
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "page.md").write_text(
        "<!-- needs: train (torch) -->\n```python\nraise SystemExit(4)\n```\n"
        "```yaml\nnot: run\n```\n```python\nprint('ran')\n```\n"
    )
    readme = tmp_path / "README.md"
    readme.write_text("See [the page](docs/page.md#x).\n")
    done = _run(str(readme))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "page.md:2 (python): skipped, needs train (torch)" in done.stdout
    assert "2 blocks: 1 ran, 1 ok, 0 failed, 1 skipped" in done.stdout
    given = _run(str(readme), "--with", "train")
    assert given.returncode == 1 and "FAILED (exit 4" in given.stdout


def test_a_page_with_nothing_to_run_fails(tmp_path: Path):
    readme = tmp_path / "README.md"
    readme.write_text("<!-- needs: checkout -->\n```bash\npip install -e .\n```\n")
    assert _run(str(readme)).returncode == 1
