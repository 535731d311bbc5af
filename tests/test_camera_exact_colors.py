"""Image-track cameras keep marking pixels at their exact colours, as tinycarlo 1.1's camera
does: colour-threshold perception written for tinycarlo must keep working."""

from __future__ import annotations

import numpy as np
import pytest

from tests.synthetic import BGR, blank, make_env, straight, write_track

# tinycarlo's shipped configs: a 480x640 (or 360x480) window seen at 120x160: 4x (3x) smaller
CAMERAS = [
    {"id": "front", "resolution": [120, 160], "roi": [480, 640], "position": [0, 0]},
    {"id": "wide", "resolution": [120, 160], "roi": [360, 480], "position": [0, 0], "yaw": 30},
]


@pytest.mark.parametrize("width", [6, 9])  # [px] marking widths of the shipped tracks
def test_thin_markings_keep_their_exact_colours(tmp_path, width):
    image = blank(1200, 1200)
    colours = ["yellow", "magenta", "white"]
    for k, name in enumerate(colours):  # three lines ahead of the car, across its path
        x = 560 + 110 * k
        image[:, x : x + width] = BGR[name]
    folder = write_track(
        tmp_path,
        image,
        {"cameras": CAMERAS, "tracks": [{"image": "track.png", "spawns": [[300, 600, 0.0]]}]},
    )
    env = make_env(folder)
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(straight())
    for camera in ("front", "wide"):
        pixels = observation[camera].reshape(-1, 3)
        for name in colours:
            exact = np.all(pixels == BGR[name][::-1], axis=1)
            assert exact.sum() >= 120 // 2, (camera, name)  # at least a pixel per other row
    env.close()
