"""Golden hashes: what every shipped env produces for 300 seeded steps, kept bit for bit.

For each case (both registered ids, and the env of every shipped experiment config) the
env is reset with a fixed seed and driven by actions drawn from a seeded
``np.random.default_rng`` over its action space, resetting (without a seed) when an
episode ends. Observation bytes, ``repr`` of each reward, the terminated and truncated
flags, the info (``json.dumps`` with sorted keys; floats as their repr) and a few
rgb_array frames are hashed with sha256, each stream on its own so that a mismatch says
which one changed.

Regenerate after an intended behaviour change:
``PYTHONPATH=. python tests/golden/record.py`` (writes tests/golden/<case>.json).
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import CONFIGS_DIR

GOLDEN_DIR = Path(__file__).resolve().parent
STEPS = 300
RESET_SEED = 1234
ACTION_SEED = 5678
FRAME_STEPS = (0, 100, 200, STEPS - 1)  # steps whose rgb_array frame is hashed too
STREAMS = ("observations", "rewards", "terminated", "truncated", "infos", "frames")


def _config_env(path: Path) -> Callable[[], gym.Env]:
    """The env of an experiment config: its ``env`` section, a relative track folder resolved."""

    def make() -> gym.Env:
        sections = dict((yaml.safe_load(path.read_text()) or {}).get("env") or {})
        folder = sections.pop("environment", None)
        if folder is not None:  # a folder relative to the config, or a shipped track's name
            relative = path.parent / folder
            sections["environment"] = str(relative.resolve()) if relative.exists() else folder
        return gym.make("tinyrace/TinyRace-v0", render_mode="rgb_array", **sections)

    return make


def cases() -> dict[str, Callable[[], gym.Env]]:
    """Every golden case by name: registered ids first, then one per shipped config."""
    found: dict[str, Callable[[], gym.Env]] = {
        "CarRacing-v0": lambda: gym.make("tinyrace/CarRacing-v0", render_mode="rgb_array"),
        "CarRacing-v0-discrete": lambda: gym.make(
            "tinyrace/CarRacing-v0", render_mode="rgb_array", continuous=False
        ),
        "TinyRace-v0": lambda: gym.make("tinyrace/TinyRace-v0", render_mode="rgb_array"),
    }
    for path in sorted(CONFIGS_DIR.glob("*.yaml")):
        found[f"config-{path.stem}"] = _config_env(path)
    return found


def _sample(space: gym.Space, rng: np.random.Generator) -> Any:
    if isinstance(space, gym.spaces.Discrete):
        return int(rng.integers(space.n))
    assert isinstance(space, gym.spaces.Box)
    return rng.uniform(space.low, space.high).astype(space.dtype)


def plain(value: Any) -> Any:
    """numpy scalars and arrays as Python values, for json (also the race hashes')."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON: {value!r}")


def _observation_bytes(observation: Any) -> bytes:
    if isinstance(observation, dict):
        return b"".join(
            key.encode() + _observation_bytes(observation[key]) for key in sorted(observation)
        )
    return array_bytes(observation)


def array_bytes(value: Any) -> bytes:
    """An array's dtype, shape and bytes: what is hashed of it (also in the race hashes)."""
    array = np.ascontiguousarray(value)
    return f"{array.dtype}{array.shape}".encode() + array.tobytes()


def run(make: Callable[[], gym.Env], steps: int = STEPS) -> dict[str, Any]:
    """Drive one env ``steps`` steps; return the sha256 of each stream and a few plain facts."""
    hashes = {name: hashlib.sha256() for name in STREAMS}
    env = make()
    rng = np.random.default_rng(ACTION_SEED)
    observation, info = env.reset(seed=RESET_SEED)
    hashes["observations"].update(_observation_bytes(observation))
    hashes["infos"].update(json.dumps(info, sort_keys=True, default=plain).encode())
    episodes, total = 1, 0.0
    for step in range(steps):
        observation, reward, terminated, truncated, info = env.step(_sample(env.action_space, rng))
        hashes["observations"].update(_observation_bytes(observation))
        hashes["rewards"].update(repr(reward).encode() + b";")
        hashes["terminated"].update(repr(terminated).encode() + b";")
        hashes["truncated"].update(repr(truncated).encode() + b";")
        hashes["infos"].update(json.dumps(info, sort_keys=True, default=plain).encode())
        total += float(reward)
        if step in FRAME_STEPS:
            hashes["frames"].update(_observation_bytes(env.render()))
        if terminated or truncated:
            observation, info = env.reset()
            hashes["observations"].update(_observation_bytes(observation))
            hashes["infos"].update(json.dumps(info, sort_keys=True, default=plain).encode())
            episodes += 1
    env.close()
    return {
        "steps": steps,
        "episodes": episodes,
        "total_reward": repr(total),
        "sha256": {name: h.hexdigest() for name, h in hashes.items()},
    }


def path_of(name: str) -> Path:
    return GOLDEN_DIR / f"{name}.json"


def main(names: list[str]) -> int:
    """Record the named cases (all when none are named)."""
    for name, make in cases().items():
        if names and name not in names:
            continue
        result = run(make)
        path_of(name).write_text(json.dumps(result, indent=2, sort_keys=True) + "\n")
        print(f"{name}: {result['episodes']} episode(s), reward {result['total_reward']}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
