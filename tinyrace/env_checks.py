"""What TinyRaceEnv checks at its doors: its true/false keywords, the reset options and
poses, and a user's ``cte_shaping`` function (each result checked as it comes). A bad value
is a ConfigError naming the keyword or option, before anything changes."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tinyrace.errors import ConfigError, Problem, did_you_mean

RESET_OPTIONS = ("randomize", "track", "spawn", "poses")
RESET_SOURCE = "<reset options>"
KWARGS_SOURCE = "<kwargs>"


def flag(value: object, key: str, source: str = KWARGS_SOURCE) -> bool:
    """A true/false keyword argument (``verbose``, CarRacing's ``continuous``): a bool, a
    numpy bool, or 0 or 1 (CarRacing-v3 reads any object's truth; code written for it may
    pass 0), else a ConfigError naming ``key`` (text such as "no" is not read as a flag:
    any non-empty string would be true)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)) and value in (0, 1):
        return bool(value)
    raise ConfigError(Problem(source, key, value, "expected true or false (or 0 or 1)"))


def check_options(options: object) -> dict[str, Any]:
    """The reset options, checked: known keys, ``randomize`` a bool, indices whole numbers.

    Image tracks check the index ranges when they pick; a procedural track has one track and
    one start, index 0.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ConfigError(Problem(RESET_SOURCE, "", options, "expected a dict or None"))
    for key, value in options.items():
        if key not in RESET_OPTIONS:
            hint = did_you_mean(key, RESET_OPTIONS)
            allowed = f"unknown option; {hint}valid: {', '.join(RESET_OPTIONS)}"
            raise ConfigError(Problem(RESET_SOURCE, _key_text(key), value, allowed))
        if key == "randomize" and not isinstance(value, (bool, np.bool_)):
            raise ConfigError(Problem(RESET_SOURCE, key, value, "expected true or false"))
    return dict(options)


def check_poses(value: object, count: int) -> list[tuple[float, float, float]] | None:
    """The ``poses`` reset option: one finite (x, y, heading) per car [track units, rad]."""
    if value is None:
        return None
    try:  # numbers only: true/false and text are no coordinates (the config refuses them too)
        raw = np.asarray(value, dtype=object)
        numbers = all(
            isinstance(x, (int, float, np.number)) and x is not True and x is not False
            for x in raw.flat
        )
        poses = raw.astype(np.float64) if numbers else np.zeros(0)
    except (TypeError, ValueError, OverflowError):
        poses = np.zeros(0)
    if poses.shape != (count, 3) or not np.isfinite(poses).all():
        allowed = f"expected {count} finite (x, y, heading) poses of numbers, one per car"
        raise ConfigError(Problem(RESET_SOURCE, "poses", _short(value), allowed))
    return [(float(x), float(y), float(h)) for x, y, h in poses.tolist()]


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _key_text(key: object) -> str:
    text = key if isinstance(key, str) else repr(key)
    return text if len(text) <= 40 else text[:37] + "..."


def checked_shaping(shaping: object) -> Callable[[float], float]:
    """The ``cte_shaping`` kwarg: a callable whose every result must be a finite number."""
    if not callable(shaping):
        allowed = (
            "expected a function cte [px] -> reward, or None "
            "(reward_design.cross_track_error.shaping names the built-in ones)"
        )
        raise ConfigError(Problem("<kwargs>", "cte_shaping", shaping, allowed))
    return _CheckedShaping(shaping)


@dataclass(frozen=True)
class _CheckedShaping:
    """Calls the user's shaping; a result that is not a finite number is a ConfigError."""

    shaping: Callable[[float], Any]

    def __call__(self, cte: float) -> float:
        value = self.shaping(cte)
        number = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
        if not (number and np.isfinite(value)):
            allowed = "expected the cte_shaping function to return a finite number"
            raise ConfigError(Problem("<kwargs>", "cte_shaping", value, allowed))
        return float(value)
