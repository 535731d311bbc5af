"""Run every shell and Python block of the README and of the docs pages it links.

Usage: python .ci/readme_examples.py [--with NEED]... [--list] [PAGE.md ...]

The interpreter running this is the one used (its folder goes first on PATH, so ``python``
and ``tinyrace`` in shell blocks are that virtualenv's): run it with the virtualenv that has
the wheel installed. PAGE defaults to the README beside this folder; the Markdown pages
under ``docs/`` that a page links (``](docs/x.md)``, ``](x.md)``) are read too, and theirs.

Each ```python, ```bash or ```sh block runs as written, in page order, all of them in ONE
new empty folder, as a reader who pastes them one after another (what a block writes, a
later block finds; the block itself is saved in another temporary folder): Python blocks
with this interpreter, shell blocks with ``bash -e -o pipefail``. A block that needs more than the
wheel says so on the line before it::

    <!-- needs: train -->
    <!-- needs: checkout, train (a reason, printed with it) -->

It runs only when every need is given with ``--with`` (after CI installed that extra);
otherwise it is listed as skipped with its needs. ```text, ```yaml and other blocks are not
run. Exit status 1 when a block fails (its output is printed) or when no block ran.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT = 600  # [s] per block
LANGUAGES = {"python": "python", "bash": "shell", "sh": "shell", "shell": "shell"}
FENCE = re.compile(r"^```([A-Za-z]*)[^\n]*\n(.*?)^```[ \t]*$", flags=re.S | re.M)
NEEDS = re.compile(r"<!--\s*needs:\s*([^()]*?)\s*(?:\((.*)\))?\s*-->\s*$")
LINK = re.compile(r"\]\(([^)#\s]+\.md)(?:#[^)]*)?\)")


@dataclass(frozen=True)
class Block:
    page: Path
    line: int  # of the opening fence, 1-based
    kind: str  # python | shell
    code: str
    needs: tuple[str, ...]
    why: str  # the marker's reason, if any

    def where(self) -> str:
        try:
            name = self.page.resolve().relative_to(ROOT).as_posix()
        except ValueError:
            name = self.page.name
        return f"{name}:{self.line} ({self.kind})"


def blocks(page: Path) -> list[Block]:
    """The runnable blocks of one page, in order."""
    text = page.read_text(encoding="utf-8")
    found = []
    for match in FENCE.finditer(text):
        kind = LANGUAGES.get(match.group(1).lower())
        if kind is None:
            continue
        before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        marker = NEEDS.search(before)
        needs: tuple[str, ...] = ()
        why = ""
        if marker:
            needs = tuple(n.strip() for n in marker.group(1).split(",") if n.strip())
            why = (marker.group(2) or "").strip()
        line = text.count("\n", 0, match.start()) + 1
        found.append(Block(page, line, kind, match.group(2), needs, why))
    return found


def pages(first: Path) -> list[Path]:
    """``first`` and the docs pages it links, transitively, each once."""
    seen = [first.resolve()]
    for page in seen:  # grows while it is walked
        for target in LINK.findall(page.read_text(encoding="utf-8")):
            if "://" in target:
                continue
            path = (page.parent / target).resolve()
            if path.parent.name == "docs" and path.is_file() and path not in seen:
                seen.append(path)
    return seen


def run(block: Block, folder: str) -> tuple[int, str, float]:
    """(exit status, output, seconds) of one block, run in ``folder``."""
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env.setdefault("SDL_VIDEODRIVER", "dummy")
    env.setdefault("SDL_AUDIODRIVER", "dummy")
    env.pop("PYTHONPATH", None)  # the installed package, not a checkout
    with tempfile.TemporaryDirectory() as scripts:
        if block.kind == "python":
            script = Path(scripts) / "example.py"
            command = [sys.executable, str(script)]
        else:
            script = Path(scripts) / "example.sh"
            command = ["bash", "-e", "-o", "pipefail", str(script)]
        script.write_text(block.code, encoding="utf-8")
        started = time.perf_counter()
        try:
            done = subprocess.run(
                command,
                cwd=folder,
                env=env,
                stdin=subprocess.DEVNULL,
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
            )
        except subprocess.TimeoutExpired as error:
            out = (error.stdout or b"").decode() if isinstance(error.stdout, bytes) else ""
            return -1, f"{out}\ntimed out after {TIMEOUT} s", time.perf_counter() - started
        return done.returncode, done.stdout + done.stderr, time.perf_counter() - started


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("pages", nargs="*", type=Path, default=[ROOT / "README.md"])
    parser.add_argument(
        "--with",
        dest="given",
        action="append",
        default=[],
        metavar="NEED",
        help="run the blocks that need NEED (repeatable)",
    )
    parser.add_argument("--list", action="store_true", help="list the blocks, run none")
    args = parser.parse_args(argv[1:])
    given = {n for item in args.given for n in item.split(",") if n}

    every = [b for first in args.pages for page in pages(first) for b in blocks(page)]
    with tempfile.TemporaryDirectory() as folder:  # one folder for every block, in order
        return _run_all(every, given, args.list, folder)


def _run_all(every: list[Block], given: set[str], listing: bool, folder: str) -> int:
    ran = failed = 0
    skipped: list[str] = []
    for block in every:
        missing = [n for n in block.needs if n not in given]
        if missing:
            reason = f" ({block.why})" if block.why else ""
            skipped.append(f"{block.where()}: needs {', '.join(block.needs)}{reason}")
            print(f"{block.where()}: skipped, needs {', '.join(missing)}{reason}", flush=True)
            continue
        if listing:
            print(f"{block.where()}: would run", flush=True)
            continue
        status, output, seconds = run(block, folder)
        ran += 1
        if status == 0:
            print(f"{block.where()}: ok ({seconds:.1f} s)", flush=True)
        else:
            failed += 1
            print(f"{block.where()}: FAILED (exit {status}, {seconds:.1f} s)", flush=True)
            print(output[-4000:], flush=True)
    print(
        f"{len(every)} blocks: {ran} ran, {ran - failed} ok, {failed} failed, "
        f"{len(skipped)} skipped",
        flush=True,
    )
    if listing:
        return 0
    if ran == 0:
        print("no block ran", file=sys.stderr)
        return 1
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
