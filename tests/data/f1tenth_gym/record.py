"""Record f1tenth_gym's car: reference trajectories for ``car.compat: f1tenth_gym``.

Not run by the tests (they read ``trajectories.npz``, which this writes next to itself).
It runs f1tenth_gym's own code, not a copy: ``RaceCar.update_pose`` (its steering buffer,
its ``pid`` controller, RK4 on its ``vehicle_dynamics_st``) from a checkout of
github.com/f1tenth/f1tenth_gym, main at 4fdb9c7 (the commit these files were made from):

    git clone https://github.com/f1tenth/f1tenth_gym /tmp/f1g
    git -C /tmp/f1g checkout 4fdb9c7
    python tests/data/f1tenth_gym/record.py /tmp/f1g

It needs numpy, numba, scipy, Pillow and PyYAML (f1tenth_gym's imports); its ``gym``
package registration is bypassed (only ``f110_gym.envs`` is loaded), and its scan
simulator is replaced by a stub (no map: only the car's motion is recorded). The car is
F1TENTH's default (f110_env.py's parameters) at 0.01 s steps with the RK4 integrator.
"""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
STEPS = 500  # 5 s at f1tenth_gym's 100 Hz
DT = 0.01
PARAMS = {  # f110_env.py's defaults
    "mu": 1.0489, "C_Sf": 4.718, "C_Sr": 5.4562, "lf": 0.15875, "lr": 0.17145, "h": 0.074,
    "m": 3.74, "I": 0.04712, "s_min": -0.4189, "s_max": 0.4189, "sv_min": -3.2,
    "sv_max": 3.2, "v_switch": 7.319, "a_max": 9.51, "v_min": -5.0, "v_max": 20.0,
    "width": 0.31, "length": 0.58,
}  # fmt: skip
LOCK = PARAMS["s_max"]


def sequences() -> dict[str, np.ndarray]:
    """(STEPS, 2) actions [steering angle rad, speed m/s] by name."""
    t = np.arange(STEPS) * DT
    found = {}
    # straight at 3 m/s, then a held left turn of 0.3 rad, then a held right one
    steer = np.where(t < 1.0, 0.0, np.where(t < 3.0, 0.3, -0.2))
    found["hold"] = np.stack([steer, np.full(STEPS, 3.0)], 1)
    # a slalom at 4 m/s, braking to 1 m/s from 3.5 s
    speed = np.where(t < 3.5, 4.0, 1.0)
    found["slalom"] = np.stack([0.35 * np.sin(2 * np.pi * t / 1.5), speed], 1)
    # below and across 0.5 m/s (the low-speed model), reversing slowly, then away at 2 m/s
    speed = np.select([t < 1.5, t < 2.5, t < 3.5], [0.4, 0.0, -0.3], 2.0)
    found["slow"] = np.stack([np.where(t < 2.0, 0.4, -0.35), speed], 1)
    # piecewise constant random actions, new every 0.2 s (speeds 0..8 m/s)
    rng = np.random.default_rng(38)
    pieces = rng.uniform([-LOCK, 0.0], [LOCK, 8.0], (STEPS // 20, 2))
    found["random"] = np.repeat(pieces, 20, axis=0)
    return found


START = (1.5, -2.0, 0.7)  # x, y, yaw: not the origin, so a frame mix-up shows


def load_f1tenth_gym(checkout: Path) -> types.ModuleType:
    """f1tenth_gym's ``f110_gym.envs.base_classes`` from ``checkout`` (no gym needed)."""
    root = checkout / "gym" / "f110_gym"
    for name, path in (("f110_gym", root), ("f110_gym.envs", root / "envs")):
        package = types.ModuleType(name)
        package.__path__ = [str(path)]  # a bare package: its __init__ imports gym
        sys.modules[name] = package
    import f110_gym.envs.base_classes as base_classes  # type: ignore[import-not-found]

    return base_classes


class NoScan:
    """Stands in for f1tenth_gym's scan simulator (a map's lidar is not recorded)."""

    def scan(self, pose: np.ndarray, rng: object) -> np.ndarray:
        return np.zeros(1)


def record(checkout: Path) -> None:
    base = load_f1tenth_gym(checkout)
    base.RaceCar.scan_simulator = NoScan()  # before the first car: its __init__ skips its own
    commit = subprocess.run(
        ["git", "-C", str(checkout), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    arrays: dict[str, np.ndarray] = {"start": np.array(START), "dt": np.array(DT)}
    for name, actions in sequences().items():
        car = base.RaceCar(PARAMS, 12345, time_step=DT, integrator=base.Integrator.RK4)
        car.reset(np.array(START))
        states = [car.state.copy()]
        for steer, speed in actions:
            car.update_pose(float(steer), float(speed))
            states.append(car.state.copy())
        arrays[f"{name}_actions"] = actions
        arrays[f"{name}_states"] = np.array(states)  # (STEPS + 1, 7), f1tenth_gym's order
    arrays["commit"] = np.array(commit or "unknown")
    np.savez_compressed(HERE / "trajectories.npz", **arrays)
    print(f"f1tenth_gym {commit}: {', '.join(sequences())} -> {HERE / 'trajectories.npz'}")


if __name__ == "__main__":
    record(Path(sys.argv[1]))
