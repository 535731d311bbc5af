"""Synthetic tinycarlo track folders for tests: a small image plus a track.yaml.

Images are built in BGR (the order ``cv2.imwrite`` takes and tinycarlo's YAML
uses); ``BGR`` holds the pure colours a binarised track may contain.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import yaml

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR

ENV_ID = "tinyrace/TinyRace-v0"
ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = TRACKS_DIR

BGR = {
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "blue": (255, 0, 0),
    "green": (0, 255, 0),
    "red": (0, 0, 255),
    "yellow": (0, 255, 255),
    "magenta": (255, 0, 255),
    "cyan": (255, 255, 0),
}

CAMERA = {"id": "front", "resolution": [60, 80], "roi": [120, 160], "position": [0, 0]}


def blank(height: int = 600, width: int = 600) -> np.ndarray:
    """A black BGR image."""
    return np.zeros((height, width, 3), np.uint8)


def square(image: np.ndarray, centre: tuple[float, float], side: int, bgr: tuple) -> None:
    """Fill a side x side square of ``bgr`` centred (to the nearest pixel) on ``centre`` (x, y)."""
    x0 = round(centre[0] - side / 2)
    y0 = round(centre[1] - side / 2)
    image[y0 : y0 + side, x0 : x0 + side] = bgr


def car_point(
    pose: tuple[float, float, float], forward: float, right: float
) -> tuple[float, float]:
    """The image point ``forward`` px ahead of and ``right`` px right of the pose (x, y, heading).

    Heading 0 is +x; on a y-down image the car's right is (-sin a, cos a).
    """
    x, y, a = pose
    return (
        x + forward * math.cos(a) - right * math.sin(a),
        y + forward * math.sin(a) + right * math.cos(a),
    )


def write_track(
    folder: Path,
    image: np.ndarray | None = None,
    config: Mapping[str, Any] | None = None,
    image_name: str = "track.png",
) -> Path:
    """Write ``image`` (BGR, if given) and a track.yaml into ``folder``; return the folder.

    ``config`` is the whole YAML mapping; when it has no ``cameras`` (nor
    ``camera``), one small front camera is added; when it has no ``tracks`` (nor
    ``track``) and an image is given, a track of that image is added.
    """
    folder.mkdir(parents=True, exist_ok=True)
    data = dict(config or {})
    if "cameras" not in data and "camera" not in data:
        data["cameras"] = [dict(CAMERA)]
    if image is not None:
        assert cv2.imwrite(str(folder / image_name), image)
        if "tracks" not in data and "track" not in data:
            h, w = image.shape[:2]
            data["tracks"] = [{"image": image_name, "spawns": [[w / 2, h / 2, 0.0]]}]
    (folder / "track.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return folder


def make_env(folder: Path, **kwargs: Any) -> gym.Env:
    """The registered env on a track folder (wrapped as gym.make wraps it)."""
    return gym.make(ENV_ID, environment=str(folder), **kwargs)


def straight() -> np.ndarray:
    """The action that keeps the kinematic car's wheels straight."""
    return np.zeros(1, np.float32)


def centroid(mask: np.ndarray) -> tuple[float, float]:
    """(x, y) mean of the True pixels of a 2-D mask."""
    ys, xs = np.nonzero(mask)
    assert len(xs), "the mask is empty"
    return float(xs.mean()), float(ys.mean())


def color_mask(rgb: np.ndarray, bgr: tuple, tolerance: int = 60) -> np.ndarray:
    """Pixels of an RGB image within ``tolerance`` per channel of the BGR colour ``bgr``."""
    target = np.array(bgr[::-1], np.int16)
    return np.all(np.abs(rgb.astype(np.int16) - target) <= tolerance, axis=-1)
