"""The package and the scripts generating its examples type-check: ``mypy`` with
``strict = true`` (pyproject.toml) finds nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_strict_is_clean():
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--no-incremental", "tinyrace", "example_tracks"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.startswith("Success: no issues found")


def test_mypy_runs_in_strict_mode():
    config = (ROOT / "pyproject.toml").read_text()
    assert "[tool.mypy]\nstrict = true" in config
    test_extra = config.split("\ntest = [", 1)[1].split("\n]", 1)[0]
    assert '"mypy' in test_extra  # the README's test command installs what this test runs
