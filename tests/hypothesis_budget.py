"""How many hypothesis examples a property test runs, how long a long run is: the README's
quick test command runs a quarter of each test's number (at least 10) and the shorter runs,
CI all of them (``HYPOTHESIS_PROFILE=ci``, which tests/conftest.py also loads as hypothesis's
profile)."""

from __future__ import annotations

import os

FULL = os.environ.get("HYPOTHESIS_PROFILE") == "ci"


def examples(full: int) -> int:
    """``full`` on CI, a quarter of it (at least 10, at most ``full``) in the quick run."""
    return full if FULL else min(full, max(10, full // 4))


def size(full: int, quick: int) -> int:
    """``full`` on CI, ``quick`` in the README's quick run (steps of a long run, say)."""
    return full if FULL else quick
