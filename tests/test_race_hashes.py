"""A race's results are kept bit for bit: every car's observations, rewards, ends and infos.

Each case races cars driven by centreline drivers (each a little faster than the car ahead
on the grid, so that they catch up and bump) for ``STEPS`` steps and hashes each stream per
car with sha256 (a camera's pixels, each state sensor's values, the rewards, the ends and
the infos apart), so a mismatch names the car and the stream. The hashes were recorded at
commit 8fb3648, before the multi-car step was made cheaper (benchmarks/race.py): making it
cheaper must change no car's result. The camera streams were re-recorded when cameras
began to draw the other cars (the merge of main into ``seeing``: only the camera
observations of cars that see another car changed; lidar, state, rewards, ends and infos
kept their hashes).

Re-record only after an intended change of a race's results (say why in the commit):
``python tests/test_race_hashes.py [case ...]`` writes tests/golden/race/<case>.json.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import pytest
from golden.record import array_bytes, plain

from tinyrace.drivers import CenterlineDriver
from tinyrace.drivers.centerline import route_of
from tinyrace.race import parallel_env

STEPS = 150
SEED = 3
STATE_AND_LIDAR = [
    {"id": "state", "type": "state"},
    {"id": "lidar", "type": "lidar", "beams": 360},
]
CASES: dict[str, dict[str, Any]] = {
    # CarRacing's chase view per car, the dynamic car's tyres and tiles
    "procedural": {"num_agents": 3},
    # the shipped 96x128 front camera, state and a lidar; walls
    "f1tenth_loop": {"environment": "f1tenth_loop", "num_agents": 4, "sensors": STATE_AND_LIDAR},
    # a bird's-eye camera, state and a lidar on a centreline track
    "circuit": {
        "environment": "circuit",
        "num_agents": 3,
        "sensors": STATE_AND_LIDAR,
        "cameras": [{"id": "front", "resolution": [96, 96], "roi": [30, 30]}],
    },
}

RECORDED_DIR = Path(__file__).resolve().parent / "golden" / "race"


def race_hashes(case: dict[str, Any], steps: int = STEPS) -> dict[str, str]:
    """sha256 per car and stream of a race driven by centreline drivers."""
    env = parallel_env(**case)
    observations, infos = env.reset(seed=SEED)
    core = env.core
    route = route_of(core)
    drivers = {}
    for i, agent in enumerate(env.possible_agents):
        base = CenterlineDriver()
        factor = 0.6 + 0.1 * i  # the cars behind are faster: they catch up
        driver = CenterlineDriver(
            top_speed=base.top_speed * factor,
            lateral_accel=base.lateral_accel * factor,
            brake_accel=base.brake_accel * factor,
        )
        driver.follow(route, env.action_space(agent), core.dt, core.action_spec.kind)
        drivers[agent] = driver
    hashes: dict[str, Any] = {}

    def add(agent: str, stream: str, data: bytes) -> None:
        hashes.setdefault(f"{agent}/{stream}", hashlib.sha256()).update(data)

    def observe(observations: dict[str, Any], infos: dict[str, Any]) -> None:
        for agent, observation in observations.items():
            if isinstance(observation, dict):
                for key in sorted(observation):
                    add(agent, f"obs:{key}", array_bytes(observation[key]))
            else:
                add(agent, "obs", array_bytes(observation))
        for agent, info in infos.items():
            add(agent, "infos", json.dumps(info, sort_keys=True, default=plain).encode())

    observe(observations, infos)
    for _ in range(steps):
        if not env.agents:
            break
        cars = core.snapshot().cars
        actions = {
            agent: drivers[agent].act(None, {"pose": cars[i].pose, "speed": cars[i].speed})
            for agent, i in ((a, env.possible_agents.index(a)) for a in env.agents)
        }
        observations, rewards, terminations, truncations, infos = env.step(actions)
        observe(observations, infos)
        for agent in rewards:
            add(agent, "rewards", repr(rewards[agent]).encode() + b";")
            ends = (terminations[agent], truncations[agent])
            add(agent, "ends", repr(ends).encode() + b";")
    env.close()
    return {key: h.hexdigest()[:16] for key, h in sorted(hashes.items())}


def path_of(name: str) -> Path:
    return RECORDED_DIR / f"{name}.json"


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_race_gives_every_car_the_recorded_results(name):
    expected = json.loads(path_of(name).read_text())
    got = race_hashes(CASES[name])
    changed = sorted(key for key in {*expected, *got} if expected.get(key) != got.get(key))
    assert not changed, f"{name}: changed {changed}"


def test_every_race_case_has_a_recording():
    assert {p.stem for p in RECORDED_DIR.glob("*.json")} == set(CASES)


if __name__ == "__main__":
    RECORDED_DIR.mkdir(parents=True, exist_ok=True)
    for name, case in CASES.items():
        if sys.argv[1:] and name not in sys.argv[1:]:
            continue
        hashes = race_hashes(case)
        path_of(name).write_text(json.dumps(hashes, indent=1, sort_keys=True) + "\n")
        print(f"{name}: {len(hashes)} streams")
