"""The worker side of the fourth hostile campaign (tests/test_hostile_round4_campaign.py):
races, per-car actions on both PettingZoo forms, reset options, opponents, camera_info
files and the cache folder. tests/hostile_worker.py runs these in its worker processes.

Each case answers an outcome: ``config_error`` (with the problems), ``invalid_action`` (with
the message), or ``ok`` once the env reset and stepped with finite observations inside each
car's observation space; anything else (a crash, a hang) is reported by the worker itself.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

RACE = {  # procedural: the dynamic car, pedals (Box(3,)) or CarRacing's five buttons
    "race": {"cars": [{"id": "pedals"}, {"id": "buttons", "car": {"actions": "discrete"}}]},
    "cameras": [],
    "sensors": [{"id": "state", "type": "state"}],
}
NEUTRAL = {"pedals": np.zeros(3, np.float32), "buttons": 0}
_ENVS: dict[str, Any] = {}
_FRESH: dict[str, bool] = {}  # per form: the last action case stepped whole (no reset needed)


def _problems(exc: Any) -> list[tuple[str, str, str]]:
    return [(p.source, p.path, str(p)) for p in exc.problems]


def _wrong(space: Any, observation: Any) -> str | None:
    """Why an observation is not finite or not inside its space (None when it is)."""
    arrays = observation.values() if isinstance(observation, dict) else [observation]
    for array in arrays:
        if (
            isinstance(array, np.ndarray)
            and array.dtype.kind == "f"
            and not np.isfinite(array).all()
        ):
            return "an observation is not finite"
    if not space.contains(observation):
        return "an observation is outside the observation space"
    return None


def _check_parallel(env: Any, observations: dict[str, Any]) -> str | None:
    for agent, observation in observations.items():
        wrong = _wrong(env.observation_space(agent), observation)
        if wrong is not None:
            return f"{agent}: {wrong}"
    return None


def _run_parallel(env: Any, steps: int, seed: int = 0) -> str | None:
    observations, _ = env.reset(seed=seed)
    wrong = _check_parallel(env, observations)
    for i in range(steps):
        if wrong is not None or not env.agents:
            break
        actions = {}
        for agent in env.agents:
            space = env.action_space(agent)
            space.seed(seed + i)
            actions[agent] = space.sample()
        observations, *_ = env.step(actions)
        wrong = _check_parallel(env, observations)
    return wrong


def race_config_case(kwargs: dict[str, Any]) -> dict[str, Any]:
    """A RaceEnv of the drawn keyword arguments (a config file among them, maybe)."""
    from tinyrace.errors import ConfigError
    from tinyrace.race import parallel_env

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = parallel_env(**kwargs)
            try:
                wrong = _run_parallel(env, 2)
            finally:
                env.close()
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok"}


def _race(form: str) -> Any:
    if form not in _ENVS:
        from tinyrace.race import aec_env, parallel_env

        _ENVS[form] = parallel_env(**RACE) if form == "parallel" else aec_env(**RACE)
    return _ENVS[form]


def action_case(form: str, car: str, action: Any) -> dict[str, Any]:
    """One step of the two-car race with ``action`` for ``car`` (the other's neutral)."""
    from gymnasium.error import InvalidAction

    env = _race(form)
    actions = {**NEUTRAL, car: action}
    if _FRESH.get(form) is not True or len(env.agents) < 2:  # else the race goes on
        env.reset(seed=0)
    _FRESH[form] = False  # until this step is done
    try:
        if form == "parallel":
            observations, *_ = env.step(actions)
            wrong = _check_parallel(env, observations)
        else:
            wrong = None
            for agent in env.agent_iter(2):
                env.step(actions[agent])
            for agent in env.agents:
                wrong = wrong or _wrong(env.observation_space(agent), env.observe(agent))
    except InvalidAction as exc:
        return {"outcome": "invalid_action", "error": str(exc)}
    _FRESH[form] = True  # a whole step: the next case may step on
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok"}


def reset_case(form: str, options: Any) -> dict[str, Any]:
    """``reset(options=...)`` on the two-car race, then one neutral step."""
    from tinyrace.errors import ConfigError

    env = _race(form)
    _FRESH[form] = False  # the action cases reset it next
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an unknown option is left out with a warning
            if form == "parallel":
                observations, _ = env.reset(seed=0, options=options)
                wrong = _check_parallel(env, observations)
                observations, *_ = env.step(dict(NEUTRAL))
                wrong = wrong or _check_parallel(env, observations)
            else:
                env.reset(seed=0, options=options)
                for agent in env.agent_iter(2):
                    env.step(NEUTRAL[agent])
                wrong = None
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok"}


@dataclass
class Scripted:
    """An opponent driver object: ``controls`` returns ``value``; ``follow`` takes
    ``follow_args`` arguments (None: it has no follow)."""

    value: Any
    follow_args: int | None

    def controls(self, pose: Any, speed: float) -> Any:
        return self.value

    def __getattr__(self, name: str) -> Any:
        if name == "follow" and self.follow_args is not None:
            count = self.follow_args
            methods = {
                0: lambda: None,
                1: lambda route: None,
                3: lambda route, space, dt: None,
                4: lambda route, space, dt, kind: None,
            }
            return methods.get(count, lambda *args: None)
        raise AttributeError(name)


def opponents_case(track: str | None, specs: list[Any]) -> dict[str, Any]:
    """``gym.make``'s opponents: each spec a mapping whose ``driver`` may be
    ("scripted", value, follow_args) for a driver object; reset and two steps."""
    from tinyrace.errors import ConfigError
    from tinyrace.race.opponents import make_env

    built: Any = [] if isinstance(specs, list) else specs  # not a list: as given
    for spec in specs if isinstance(specs, list) else ():
        if isinstance(spec, dict) and isinstance(spec.get("driver"), tuple):
            _, value, follow_args = spec["driver"]
            spec = {**spec, "driver": Scripted(value, follow_args)}
        built.append(spec)
    where = {} if track is None else {"environment": track}
    try:
        env = make_env(opponents=built, cameras=[], sensors=[{"id": "s", "type": "state"}], **where)
        try:
            env.action_space.seed(0)
            observation, _ = env.reset(seed=0)
            wrong = _wrong(env.observation_space, observation)
            for _ in range(2):
                observation, *_ = env.step(env.action_space.sample())
                wrong = wrong or _wrong(env.observation_space, observation)
        finally:
            env.close()
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok"}


@dataclass
class Table:
    values: np.ndarray
    scale: float


BIG = 200_000  # float64 values: 1.6 MB, a disk entry


def cache_case(folder: str, key: str, clear: bool) -> dict[str, Any]:
    """``cache.shared`` of a table in a hostile cache folder (twice: built, then mapped or
    built again), then maybe ``clear``: the value must be right every time."""
    from pathlib import Path

    from tinyrace import cache
    from tinyrace.cache import disk
    from tinyrace.cache.codec import DataclassCodec

    codec = DataclassCodec(Table)
    settings = cache.Settings(Path(folder))
    told = []
    for _ in range(2):
        cache.forget()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            table = cache.shared(
                key, lambda: Table(np.arange(BIG, dtype=np.float64), 1.5), settings, codec
            )
        told += [str(w.message) for w in caught]
        if table.values.shape != (BIG,) or table.values[-1] != BIG - 1 or table.scale != 1.5:
            return {"outcome": "bad_value", "error": "the shared value is not the one built"}
    cache.forget()
    removed = disk.clear(Path(folder)) if clear else 0
    return {"outcome": "ok", "warnings": told[-3:], "removed": removed}


def is_finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


CASES = {
    "race_config": race_config_case,
    "action": action_case,
    "reset": reset_case,
    "opponents": opponents_case,
    "cache": cache_case,
}
