"""What drawing the other cars costs a race: steps to count instructions of under callgrind.

``python benchmarks/race_drawing.py CAMERA DRAW STEPS [--cars N]``: a race of N cars (8)
on the circuit (``birdseye``: a 96x96 birdseye camera each; ``perspective``: a 120x160
pinhole camera each) or CarRacing's track (``carracing``: its 96x96 view each) takes 60
warm-up steps with a little gas, then ``STEPS`` more; ``DRAW`` ``off`` replaces the drawing
of the other cars (``sensors/machinery/draw_cars.py``) by nothing. Run it with ``STEPS`` = 0 and K
under ``valgrind --tool=callgrind``; instructions per race step = (Ir(K) - Ir(0)) / K;
the drawing's share = 1 - off / on.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from tinyrace.race import parallel_env

WARMUP = 60  # [steps]
CAMERAS: dict[str, dict[str, Any]] = {
    "birdseye": {
        "environment": "circuit",
        "cameras": [{"id": "camera", "resolution": [96, 96], "roi": [20, 20]}],
    },
    "perspective": {
        "environment": "circuit",
        "cameras": [],
        "sensors": [{"id": "camera", "type": "perspective_camera", "resolution": [120, 160]}],
    },
    "carracing": {},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("camera", choices=sorted(CAMERAS))
    parser.add_argument("draw", choices=("on", "off"))
    parser.add_argument("steps", type=int)
    parser.add_argument("--cars", type=int, default=8)
    args = parser.parse_args()
    if args.draw == "off":
        from tinyrace.sensors import birdseye_camera, chase_view, perspective_camera, top_view

        def nothing(*_: Any, **__: Any) -> None:
            return None

        setattr(birdseye_camera, "fill_footprints", nothing)  # noqa: B010 (a stand-in)
        setattr(chase_view, "fill_footprints", nothing)  # noqa: B010
        setattr(top_view, "fill_footprints", nothing)  # noqa: B010
        setattr(perspective_camera, "fill_footprints_seen", nothing)  # noqa: B010
    env = parallel_env(num_agents=args.cars, **CAMERAS[args.camera])
    env.reset(seed=0)
    gas = np.zeros(env.action_space("car_0").shape or (), np.float32)
    gas[1] = 0.3  # [steer, gas(, brake)]: every car rolls ahead
    for _ in range(WARMUP + args.steps):
        env.step({agent: gas for agent in env.agents})


if __name__ == "__main__":
    main()
