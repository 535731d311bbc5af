"""Type checking is CI's own stage (.ci/run runs ``python -m mypy``), not a test of the
README's test command: here only that it stays strict and covers what it should."""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_is_strict_over_the_package_the_examples_and_the_toys() -> None:
    mypy = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    assert mypy["strict"] is True
    files = set(mypy["files"])
    assert {"tinyrace", "example_tracks"} <= files
    assert {"tests/test_toy_recipes.py", "tests/test_toy_car_model.py"} <= files
    assert all((ROOT / f).exists() for f in files)


def test_ci_runs_mypy_as_its_own_stage() -> None:
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    assert "python -m mypy" in lines  # on pyproject's files, as configured
