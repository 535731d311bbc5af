"""Make the tests' helper modules (synthetic, drivers_for_tests) importable in any layout.

pytest's default import mode already puts this folder on sys.path; this also covers
``--import-mode=importlib`` and a run from the unpacked sdist against an installed wheel.
"""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)

if "TINYRACE_CACHE_DIR" not in os.environ:  # the tests' cache files go to a folder of their own
    _CACHE = tempfile.mkdtemp(prefix="tinyrace-test-cache-")
    os.environ["TINYRACE_CACHE_DIR"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, True)

import gymnasium as gym  # noqa: E402
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

import tinyrace  # noqa: E402, F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR  # noqa: E402

# HYPOTHESIS_PROFILE=ci (.ci/run): every test's full number of examples (hypothesis_budget.py);
# unset: the README's quick run, a quarter of them
settings.register_profile("ci", print_blob=True)
settings.register_profile("quick")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "quick"))


@pytest.fixture
def no_display(monkeypatch: pytest.MonkeyPatch) -> None:
    """SDL's dummy drivers: a human render opens a window on no display."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")


@pytest.fixture
def carracing():
    """tinyrace/CarRacing-v0 with rgb_array rendering, reset with seed 0; closed after."""
    env = gym.make("tinyrace/CarRacing-v0", render_mode="rgb_array")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.fixture
def image_track_env():
    """The formula_student image track (kinematic car, one camera), reset with seed 0."""
    env = gym.make(
        "tinyrace/TinyRace-v0",
        environment=str(TRACKS_DIR / "formula_student"),
        render_mode="rgb_array",
    )
    env.reset(seed=0)
    yield env
    env.close()


def _uses_budget(module: object) -> bool:
    """Whether a test module takes its sizes from hypothesis_budget (examples, size)."""
    return any(
        getattr(value, "__module__", None) == "hypothesis_budget"
        or getattr(value, "__name__", None) == "hypothesis_budget"
        for value in vars(module).values()
    )


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark ``budget`` every test sized by hypothesis_budget: the tests that CI's profile
    makes longer, which CI also runs against the built wheel (.ci/run)."""
    for item in items:
        module = getattr(item, "module", None)
        if module is not None and _uses_budget(module):
            item.add_marker(pytest.mark.budget)
