"""A still picture of a whole track, for ``tinyrace show``: the road or markings, start poses,
the trajectory and a legend of what the colours mean."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from gymnasium.utils import seeding

from tinyrace.config import EnvConfig
from tinyrace.ground.procedural import GroundPainter
from tinyrace.ground.texture import GroundTexture, transform_points
from tinyrace.tracks.base import Track
from tinyrace.tracks.procedural_source import GroundColors, ProceduralSource

MAX_SIDE = 1600  # [px] longest side of a picture
SPAWN_COLOR = (255, 60, 60)  # RGB
TEXT_COLOR = (255, 255, 255)
_FONT = cv2.FONT_HERSHEY_SIMPLEX


MARGIN = 40  # [px] around the track's extent in procedural pictures


@dataclass(frozen=True)
class PictureFrame:
    """Where world points land in a picture: ``px = x * sx + ox``, ``py = y * sy + oy``."""

    sx: float
    ox: float
    sy: float
    oy: float

    def matrix(self) -> np.ndarray:
        """The 2x3 affine of ``pixels``."""
        return np.array([[self.sx, 0.0, self.ox], [0.0, self.sy, self.oy]])

    def pixels(self, points: np.ndarray) -> np.ndarray:
        """(..., 2) world points [track units] to (..., 2) pixel coordinates (float)."""
        points = np.asarray(points, float)
        return np.stack(
            [points[..., 0] * self.sx + self.ox, points[..., 1] * self.sy + self.oy], axis=-1
        )


def painted_ground(track: Track, playfield: float) -> tuple[np.ndarray, PictureFrame]:
    """The track's painted ground (its tiles and kerbs, in its palette), north up, cropped
    to the track and its kerbs plus a margin (the texture's black padding beyond the
    playfield never shows)."""
    assert track.tiles is not None, "a painted ground has tiles"
    colors = GroundColors.of(track)
    ppu = MAX_SIDE / (2 * playfield)  # [px/u]
    texture = GroundPainter(playfield).paint(track, colors, ppu)
    image = cv2.cvtColor(texture.image(0), cv2.COLOR_RGBA2RGB)[::-1]
    full = PictureFrame(ppu, playfield * ppu, -ppu, image.shape[0] - playfield * ppu)
    corners = full.pixels(np.concatenate([track.tiles.reshape(-1, 2), track.kerbs.reshape(-1, 2)]))
    inside = round(2 * playfield * ppu)  # the playfield's pixels, without the padding
    top = image.shape[0] - inside
    x0, y0 = np.maximum(np.floor(corners.min(axis=0)) - MARGIN, (0, top)).astype(int)
    x1, y1 = np.minimum(np.ceil(corners.max(axis=0)) + MARGIN, (inside, image.shape[0]))
    crop = np.ascontiguousarray(image[y0 : int(y1), x0 : int(x1)])
    return crop, PictureFrame(full.sx, full.ox - x0, full.sy, full.oy - y0)


def procedural_picture(config: EnvConfig, seed: int) -> np.ndarray:
    """The track CarRacing would draw for ``seed``, north up, with the start and tile 0."""
    source = ProceduralSource(config)
    rng = seeding.np_random(seed)[0]  # what reset(seed=seed) gives the env
    track = source.draw(rng, {}).track  # the env's reset order
    assert track.tiles is not None
    image, frame = painted_ground(track, source.config.playfield)
    x, y, heading = track.spawns[0]
    start = frame.pixels(np.array([x, y]))
    _arrow(image, tuple(start), (math.cos(heading), -math.sin(heading)), 40)
    lines = [
        f"procedural track, seed {seed}",
        f"{len(track.tiles)} tiles, {len(track.kerbs)} kerbs",
    ]
    _legend(image, [(None, text) for text in lines] + [(SPAWN_COLOR, "start (tile 0)")])
    return image


def image_ground(config: EnvConfig, track: Track) -> tuple[np.ndarray, PictureFrame]:
    """The track image (trajectory drawn back), scaled to at most MAX_SIDE."""
    assert track.picture is not None, "a track with a picture"
    width, height = track.picture_size
    scale = min(1.0, MAX_SIDE / max(width, height))
    rgb = cv2.cvtColor(track.picture, cv2.COLOR_RGBA2RGB)
    cte = config.reward_design.cross_track_error
    trajectory = track.trajectory_points
    if trajectory is not None:
        xs, ys = trajectory[:, 0], trajectory[:, 1]
        rgb[ys, xs] = cte.trajectory_color
    size = (max(1, round(width * scale)), max(1, round(height * scale)))
    image = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA) if scale < 1 else rgb
    return image, PictureFrame(size[0] / width, 0.0, size[1] / height, 0.0)


def image_picture(config: EnvConfig, track: Track) -> np.ndarray:
    """The track image with the trajectory drawn back, spawns as arrows, and a colour legend."""
    image, frame = image_ground(config, track)
    cte = config.reward_design.cross_track_error
    for j, (x, y, heading) in enumerate(track.spawns):
        start = tuple(frame.pixels(np.array([x, y])))
        tip = _arrow(image, start, (math.cos(heading), math.sin(heading)), 40)
        cv2.putText(
            image, str(j), (int(tip[0]) + 4, int(tip[1])), _FONT, 0.6, SPAWN_COLOR, 2, cv2.LINE_AA
        )
    entries: list[tuple[tuple[int, int, int] | None, str]] = [
        (o.color, f"obstacle {o.color!r}: {o.reward}") for o in config.reward_design.color_obstacles
    ]
    if track.trajectory_points is not None:
        entries.append((cte.trajectory_color, f"trajectory {cte.trajectory_color!r}"))
    entries.append((SPAWN_COLOR, "spawns (index, heading)"))
    _legend(image, entries)
    return image


def metric_ground(track: Track, texture: GroundTexture) -> tuple[np.ndarray, PictureFrame]:
    """A track in metres, north up, its longest side MAX_SIDE px: the road or map, cones."""
    x0, y0, x1, y1 = track.bounds
    scale = MAX_SIDE / max(x1 - x0, y1 - y0)  # [px/m]
    size = (max(round((x1 - x0) * scale), 1), max(round((y1 - y0) * scale), 1))
    frame = PictureFrame(scale, -x0 * scale, -scale, y1 * scale)
    return texture.warp(frame.matrix(), size), frame


def framed_bounds(track: Track) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) [m] of what a picture of a track in metres shows: its road, cones
    and walls with a margin (a twentieth of their extent, at least 1 m), within the
    playfield (``track.bounds``, which also holds the grass an episode may cross: a
    centreline track's 50 m margin would make a small track a speck)."""
    held = [a.reshape(-1, 2) for a in (track.tiles, track.walls) if a is not None and a.size]
    if len(track.cones):
        held.append(track.cones[:, :2])
    if not held:
        return track.bounds
    points = np.concatenate(held)
    low, high = points.min(axis=0), points.max(axis=0)
    margin = max(0.05 * float(np.max(high - low)), 1.0)
    x0, y0, x1, y1 = track.bounds
    return (
        max(float(low[0]) - margin, x0),
        max(float(low[1]) - margin, y0),
        min(float(high[0]) + margin, x1),
        min(float(high[1]) + margin, y1),
    )


def metric_picture(
    track: Track,
    texture: GroundTexture,
    playfield: tuple[float, float, float, float] | None = None,
) -> np.ndarray:
    """A track in metres, north up: the road or map, cones, the reference line, the start;
    all of ``track.bounds``, which the legend names ``playfield`` when that is larger."""
    image, frame = metric_ground(track, texture)
    matrix = frame.matrix()
    x0, y0, x1, y1 = track.bounds
    size = f"{track.kind} track, {(x1 - x0):.0f} x {(y1 - y0):.0f} m"
    if playfield is not None and playfield != track.bounds:
        px0, py0, px1, py1 = playfield
        size += f" shown (playfield {(px1 - px0):.0f} x {(py1 - py0):.0f} m)"
    entries: list[tuple[tuple[int, int, int] | None, str]] = [(None, size)]
    if track.circuit is not None:
        points = track.circuit.centerline
        line = transform_points(matrix, np.vstack((points, points[:1])))
        cv2.polylines(
            image, [np.round(line * 16).astype(np.int32)], False, (255, 255, 255), 1, cv2.LINE_AA, 4
        )
        circuit = track.circuit
        entries.append((None, f"{circuit.length:.0f} m, {len(circuit.tiles)} tiles"))
        entries.append(((255, 255, 255), "reference line"))
    else:
        entries.append((None, "no reference line (no waypoints): no laps, no cte"))
    if len(track.cones):
        entries.append((None, f"{len(track.cones)} cones"))
    if len(track.walls):
        entries.append(((0, 0, 0), f"walls ({len(track.walls)} boxes)"))
    x, y, heading = track.spawns[0]
    start = transform_points(matrix, np.array([x, y]))
    _arrow(image, (start[0], start[1]), (math.cos(heading), -math.sin(heading)), 40)
    entries.append((SPAWN_COLOR, "start, facing the direction of travel"))
    _legend(image, entries)
    return image


def ground_picture(
    config: EnvConfig, track: Track, texture: Callable[[], GroundTexture]
) -> tuple[np.ndarray, PictureFrame]:
    """The ground under a whole track, north up, by what the track holds: its painted
    ground (tiles and kerbs), its picture, or else the ground drawn from its road, cones
    and cells (``texture()``: the cameras' texture of it)."""
    if track.painted is not None:
        return painted_ground(track, track.painted.playfield)
    if track.picture is not None:
        return image_ground(config, track)
    return metric_ground(track, texture())


def _arrow(
    image: np.ndarray, start: tuple[float, float], direction: tuple[float, float], length: float
) -> tuple[float, float]:
    tip = (start[0] + direction[0] * length, start[1] + direction[1] * length)
    cv2.circle(image, (round(start[0]), round(start[1])), 5, SPAWN_COLOR, -1, cv2.LINE_AA)
    p0, p1 = (round(start[0]), round(start[1])), (round(tip[0]), round(tip[1]))
    cv2.arrowedLine(image, p0, p1, SPAWN_COLOR, 2, cv2.LINE_AA, tipLength=0.3)
    return tip


def _legend(image: np.ndarray, entries: Sequence[tuple[tuple[int, int, int] | None, str]]) -> None:
    """Swatches and labels in a dark box at the bottom left."""
    row, pad = 22, 8
    box_h = row * len(entries) + pad
    box_w = max(cv2.getTextSize(text, _FONT, 0.5, 1)[0][0] for _, text in entries) + 40
    top = image.shape[0] - box_h - pad
    cv2.rectangle(image, (pad, top), (pad + box_w, top + box_h), (30, 30, 30), -1)
    for k, (color, text) in enumerate(entries):
        y = top + pad + k * row
        if color is not None:
            cv2.rectangle(
                image, (pad + 6, y + 2), (pad + 22, y + 16), tuple(int(c) for c in color), -1
            )
            cv2.rectangle(image, (pad + 6, y + 2), (pad + 22, y + 16), (200, 200, 200), 1)
        cv2.putText(image, text, (pad + 30, y + 14), _FONT, 0.5, TEXT_COLOR, 1, cv2.LINE_AA)
