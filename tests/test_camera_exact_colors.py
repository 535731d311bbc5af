"""Image-track cameras keep marking pixels at their exact colours, as tinycarlo 1.1's camera
does: colour-threshold perception written for tinycarlo must keep working."""

from __future__ import annotations

import numpy as np
import pytest

from tests.synthetic import BGR, EXAMPLES, blank, make_env, straight, write_track

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


def test_gray_and_classes_formats_of_a_birdseye_camera():
    """Labels are the track's layers, sampled without blending: where the rgb image shows a
    layer's exact colour, the label image (same window) names that layer."""
    window = {"resolution": [60, 80], "roi": [360, 480]}
    cameras = [
        {"id": "rgb", **window},
        {"id": "gray", **window, "format": "gray"},
        {"id": "labels", **window, "format": "classes"},
    ]
    env = make_env(EXAMPLES / "segmented", cameras=cameras)
    observation, info = env.reset(seed=0)
    for _ in range(10):
        observation, *_ = env.step(straight())
    table = info["sensor_labels"]["labels"]
    rgb, labels = observation["rgb"], observation["labels"]
    assert observation["gray"].shape == (60, 80) and labels.shape == (60, 80)
    assert set(np.unique(labels)) <= set(table)  # {label: name}, no sky from above
    checked = 0
    for label, name in table.items():
        if "#" not in name:
            continue
        rgb_color = tuple(int(name[-6:][i : i + 2], 16) for i in (0, 2, 4))
        exact = np.all(rgb == rgb_color, axis=-1)
        if not exact.any():
            continue  # not in view
        checked += exact.sum()
        assert (labels[exact] == label).mean() > 0.95, name  # edge pixels may round apart
    assert checked > 50
    env.close()
