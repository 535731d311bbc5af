"""How many hypothesis examples a property test runs: the README's quick test command runs a
quarter of each test's number (at least 10), CI all of them (``HYPOTHESIS_PROFILE=ci``, which
tests/conftest.py also loads as hypothesis's profile)."""

from __future__ import annotations

import os

FULL = os.environ.get("HYPOTHESIS_PROFILE") == "ci"


def examples(full: int) -> int:
    """``full`` on CI, a quarter of it (at least 10, at most ``full``) in the quick run."""
    return full if FULL else min(full, max(10, full // 4))
