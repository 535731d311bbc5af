"""Side-by-side pictures of tinyrace/CarRacing-v0 and Gymnasium's CarRacing-v3.

Both envs start from the same seed and are driven by the same built-in
centreline driver (each following its own copy of the identical track), so
that the same step shows the same scene. Writes, next to this file:

- ``carracing_side_by_side.png``: the 600x400 ``rgb_array`` frames, tinyrace left;
- ``carracing_observations.png``: the 96x96 observations, scaled up 4x (nearest).

Run from the repository root: ``python docs/make_comparison.py`` (needs
``gymnasium[box2d]`` for the reference).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.drivers import CenterlineDriver, Route

HERE = Path(__file__).resolve().parent
SHOTS = (  # (title, seed, step, env kwargs)
    ("seed 0, step 1: zooming in", 0, 1, {}),
    ("seed 0, step 60: on the start line", 0, 60, {}),
    ("seed 0, step 180: first corner", 0, 180, {}),
    ("seed 3, step 420: mid-lap", 3, 420, {}),
    ("seed 1, step 120: domain_randomize", 1, 120, {"domain_randomize": True}),
)
UPSCALE = 4  # 96x96 -> 384x384
LABEL = 28  # [px] height of the caption strip


def reference_pose(env: gym.Env) -> tuple[tuple[float, float, float], float]:
    """CarRacing-v3's hull as tinyrace reports its car: (x, y, heading), speed."""
    hull = env.unwrapped.car.hull
    x, y = hull.position
    return (x, y, hull.angle + math.pi / 2), hull.linearVelocity.length


def reference_route(env: gym.Env) -> Route:
    points = np.array(env.unwrapped.track, float)[:, 2:4]
    return Route(points, True, False, 1.0, steer_lock=0.4, steer_per_rad=1.0)


def shoot(seed: int, steps: int, kwargs: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(frame, observation) of both envs after ``steps`` driven steps."""
    ours = gym.make("tinyrace/CarRacing-v0", render_mode="rgb_array", **kwargs)
    reference = gym.make("CarRacing-v3", render_mode="rgb_array", **kwargs)
    observation, info = ours.reset(seed=seed)
    reference_observation, _ = reference.reset(seed=seed)
    driver, reference_driver = CenterlineDriver(), CenterlineDriver()
    driver.reset(ours)
    reference_driver.follow(reference_route(reference), reference.action_space, 1 / 50)
    for _ in range(steps):
        observation, *_, info = ours.step(driver.act(observation, info))
        pose, speed = reference_pose(reference)
        action = reference_driver.act(reference_observation, {"pose": pose, "speed": speed})
        reference_observation, *_ = reference.step(action)
    shots = {
        "tinyrace/CarRacing-v0": (ours.render(), observation),
        "CarRacing-v3": (reference.render(), reference_observation),
    }
    ours.close()
    reference.close()
    return shots


def caption(image: np.ndarray, text: str) -> np.ndarray:
    strip = np.full((LABEL, image.shape[1], 3), 255, np.uint8)
    cv2.putText(strip, text, (6, LABEL - 9), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1)
    return np.concatenate((strip, image))


def grid(rows: list[list[np.ndarray]], gap: int = 6) -> np.ndarray:
    """Images in rows, white gaps between them."""
    height = max(image.shape[0] for row in rows for image in row)
    lines = []
    for row in rows:
        cells = []
        for image in row:
            pad = np.full((height - image.shape[0], image.shape[1], 3), 255, np.uint8)
            cells += [np.concatenate((image, pad)), np.full((height, gap, 3), 255, np.uint8)]
        lines += [np.concatenate(cells[:-1], axis=1)]
        lines += [np.full((gap, lines[-1].shape[1], 3), 255, np.uint8)]
    return np.concatenate(lines[:-1])


def main() -> None:
    frames, observations = [], []
    for title, seed, step, kwargs in SHOTS:
        shots = shoot(seed, step, kwargs)
        frames.append([caption(frame, f"{name}  |  {title}") for name, (frame, _) in shots.items()])
        observations.append(
            [
                caption(
                    np.repeat(np.repeat(obs, UPSCALE, axis=0), UPSCALE, axis=1),
                    f"{name.split('/')[-1]}  |  {title}",
                )
                for name, (_, obs) in shots.items()
            ]
        )
    outputs = {"carracing_side_by_side": frames, "carracing_observations": observations}
    for name, rows in outputs.items():
        path = HERE / f"{name}.png"
        cv2.imwrite(str(path), cv2.cvtColor(grid(rows), cv2.COLOR_RGB2BGR))
        print(f"wrote {path.relative_to(HERE.parent)}")


if __name__ == "__main__":
    main()
