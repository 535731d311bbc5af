"""docs/ARCHITECTURE.md's recipes run as printed: every Python block of the page, each in a
fresh interpreter in an empty folder (the package as installed, nothing of this checkout's
tests on the path), completes; the blocks assert their own behaviour (the new part is
registered from outside the package and ``gym.make`` builds and steps with it)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[1] / "docs" / "ARCHITECTURE.md"
FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```[ \t]*$", flags=re.S | re.M)


def _blocks() -> dict[str, str]:
    """Each Python block of the page by the heading above it (and its line)."""
    text = PAGE.read_text()
    found = {}
    for match in FENCE.finditer(text):
        before = text[: match.start()]
        heading = re.findall(r"^#+ (.+)$", before, flags=re.M)[-1]
        found[f"{heading} (line {before.count(chr(10)) + 1})"] = match[1]
    return found


BLOCKS = _blocks()


def test_the_page_has_a_block_for_each_recipe() -> None:
    headings = " ".join(BLOCKS)
    for recipe in ("Add a track source", "Add a car model", "Add a sensor"):
        assert recipe in headings, f"no python block under {recipe!r}"


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_each_recipe_runs_as_printed(name: str, tmp_path: Path) -> None:
    script = tmp_path / "recipe.py"
    script.write_text(BLOCKS[name])
    folder = tmp_path / "empty"
    folder.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    done = subprocess.run(
        [sys.executable, str(script)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, f"{name} failed:\n{done.stdout}\n{done.stderr}"
    assert list(folder.iterdir()) == []  # a recipe leaves nothing behind
