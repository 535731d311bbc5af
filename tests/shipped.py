"""Everything tinyrace ships, as env factories by name: the registered ids, the example
tracks and the experiment configs (their env made as ``tinyrace run`` makes it)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR
from tinyrace.experiment import load_experiment

IDS = sorted(k for k in gym.registry if k.startswith("tinyrace/"))
TRACKS = sorted(p.parent for p in TRACKS_DIR.glob("*/track.yaml"))
CONFIGS = sorted(CONFIGS_DIR.glob("*.yaml"))

EnvFactory = Callable[..., gym.Env[Any, Any]]


def _id(env_id: str) -> EnvFactory:
    return lambda **kw: gym.make(env_id, **kw)


def _track(folder: Any) -> EnvFactory:
    return lambda **kw: gym.make("tinyrace/TinyRace-v0", environment=str(folder), **kw)


def _config(path: Any) -> EnvFactory:
    def make(**kw: Any) -> gym.Env[Any, Any]:
        return gym.make("tinyrace/TinyRace-v0", **load_experiment(path).env_kwargs, **kw)

    return make


def shipped_envs() -> dict[str, EnvFactory]:
    """``id:...``, ``track:...`` and ``config:...`` factories taking gym.make keywords."""
    envs = {f"id:{env_id}": _id(env_id) for env_id in IDS}
    envs.update({f"track:{folder.name}": _track(folder) for folder in TRACKS})
    envs.update({f"config:{path.stem}": _config(path) for path in CONFIGS})
    return envs
