"""The overview of an image track: the whole picture (downscaled once), the car, its cameras.

The background (track image with the trajectory drawn back in) is prepared once
per track; a frame copies it and draws the car's footprint, each camera's
window outline and the camera images inset along the top.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tinyrace.config import Color
from tinyrace.config.schema import MAX_FRAME_PIXELS
from tinyrace.sensors.machinery.draw_cars import CarLooks, draw_race
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

FOOTPRINT_COLOR = (255, 64, 64)  # RGB
CAR_COLOR = (204, 0, 0)
ROI_COLORS = ((255, 200, 0), (0, 200, 255), (255, 0, 200), (120, 255, 120))
INSET_FRACTION = 0.25  # inset camera images take at most this share of the frame width each
_BITS = 3


class Overview:
    """Draws overview frames of one image track."""

    def __init__(self, track: Track, downscale: float, trajectory_color: Color | None):
        assert track.picture is not None, "an overview of a picture track"
        width, height = track.picture_size
        self.scale = 1.0 / downscale  # [overview px per track px]
        size = (max(1, round(width * self.scale)), max(1, round(height * self.scale)))
        if size[0] * size[1] > MAX_FRAME_PIXELS:  # no downscale knob allocates gigabytes
            self.scale = math.sqrt(MAX_FRAME_PIXELS / (width * height))
            size = (max(1, math.floor(width * self.scale)), max(1, math.floor(height * self.scale)))
        rgb = cv2.cvtColor(track.picture, cv2.COLOR_RGBA2RGB)
        interpolation = cv2.INTER_AREA if self.scale < 1 else cv2.INTER_NEAREST
        self.background = (
            cv2.resize(rgb, size, interpolation=interpolation) if size != (width, height) else rgb
        )
        trajectory = track.trajectory_points
        if trajectory is not None and trajectory_color is not None:
            points = np.round(trajectory * self.scale).astype(np.int64)
            points[:, 0] = points[:, 0].clip(0, size[0] - 1)
            points[:, 1] = points[:, 1].clip(0, size[1] - 1)
            self.background[points[:, 1], points[:, 0]] = trajectory_color

    def render(
        self,
        footprint: np.ndarray,
        windows: list[np.ndarray],
        images: list[np.ndarray],
        race: tuple[Snapshot, CarLooks] | None = None,
    ) -> np.ndarray:
        """A frame: ``footprint`` (4, 2) and camera ``windows`` (4, 2 each) in track px;
        ``race``: a snapshot of several cars, the others drawn and every car named."""
        frame: np.ndarray = self.background.copy()
        thickness = max(1, round(2 * min(frame.shape[:2]) / 800))
        for k, corners in enumerate(windows):
            color = ROI_COLORS[k % len(ROI_COLORS)]
            cv2.polylines(
                frame, [self._pixels(corners)], True, color, thickness, cv2.LINE_AA, _BITS
            )
        cv2.fillConvexPoly(frame, self._pixels(footprint), CAR_COLOR, cv2.LINE_AA, _BITS)
        cv2.polylines(
            frame, [self._pixels(footprint)], True, FOOTPRINT_COLOR, thickness, cv2.LINE_AA, _BITS
        )
        if race is not None and len(race[0].cars) > 1:
            draw_race(frame, np.array([[self.scale, 0, 0], [0, self.scale, 0]]), *race)
        self._inset(frame, images)
        return frame

    def _pixels(self, points: np.ndarray) -> np.ndarray:
        return np.round(points * self.scale * (1 << _BITS)).astype(np.int32)

    def _inset(self, frame: np.ndarray, images: list[np.ndarray]) -> None:
        """Camera images side by side along the top-left, each framed in its roi colour."""
        x = 4
        max_w = max(1, int(frame.shape[1] * INSET_FRACTION))
        max_h = max(1, frame.shape[0] // 3)
        for k, image in enumerate(images):
            h, w = image.shape[:2]
            factor = min(max_w / w, max_h / h, 1.0)
            small = cv2.resize(
                image,
                (max(1, int(w * factor)), max(1, int(h * factor))),
                interpolation=cv2.INTER_AREA,
            )
            sh, sw = small.shape[:2]
            if x + sw + 2 > frame.shape[1] or sh + 6 > frame.shape[0]:
                break
            frame[4 : 4 + sh, x : x + sw] = small
            cv2.rectangle(frame, (x - 1, 3), (x + sw, 4 + sh), ROI_COLORS[k % len(ROI_COLORS)], 1)
            x += sw + 6
