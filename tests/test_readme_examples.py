"""The README's Python examples run as written, each from an empty folder."""

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
    spec.loader.exec_module(module)
    return module


def test_the_readme_has_runnable_examples():
    runner = _runner()
    found = runner.examples(ROOT / "README.md")
    core = [code for _, code in found if runner.needs_optional(code) is None]
    assert len(core) >= 2 and any("gym.make(" in code for code in core)


def test_every_core_readme_example_runs_from_an_empty_folder():
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(ROOT / "README.md")],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "FAILED" not in done.stdout and ": ok" in done.stdout


def test_a_broken_example_fails_the_runner(tmp_path: Path):
    readme = tmp_path / "README.md"
    readme.write_text("# x\n\n```python\nimport tinyrace\nraise SystemExit(3)\n```\n")
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(readme)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 1 and "FAILED (exit 3)" in done.stdout


def test_examples_that_name_an_extra_are_listed_not_run(tmp_path: Path):
    readme = tmp_path / "README.md"
    readme.write_text("```python\n# needs: gymnasium[other]\nraise SystemExit(4)\n```\n")
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(readme)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0 and "needs gymnasium[other]" in done.stdout
