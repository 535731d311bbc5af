"""A still picture of a whole track, for ``tinyrace show``: the road or markings, start poses,
the trajectory and a legend of what the colours mean."""

from __future__ import annotations

import math

import cv2
import numpy as np
from gymnasium.utils import seeding

from tinyrace.config import EnvConfig
from tinyrace.episodes.procedural import config_colors, draw_colors, track_params
from tinyrace.render.procedural_ground import GroundPainter
from tinyrace.render.texture import GroundTexture, transform_points
from tinyrace.track.image import ImageTrack
from tinyrace.track.procedural import generate_track
from tinyrace.tracks.metric import MetricTrack

MAX_SIDE = 1600  # [px] longest side of a picture
SPAWN_COLOR = (255, 60, 60)  # RGB
TEXT_COLOR = (255, 255, 255)
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def procedural_picture(config: EnvConfig, seed: int) -> np.ndarray:
    """The track CarRacing would draw for ``seed``, north up, with the start and tile 0."""
    track_config = config.tracks[0]
    rng = seeding.np_random(seed)[0]  # what reset(seed=seed) gives the env
    colors = draw_colors(rng) if track_config.domain_randomize else config_colors(track_config)
    track = generate_track(rng, track_params(track_config))
    playfield = track_config.playfield
    ppu = MAX_SIDE / (2 * playfield)
    texture = GroundPainter(playfield).paint(track, colors, ppu)
    image = np.ascontiguousarray(cv2.cvtColor(texture.levels[0], cv2.COLOR_RGBA2RGB)[::-1])

    def to_pixels(x: float, y: float) -> tuple[float, float]:
        return (x + playfield) * ppu, (playfield - y) * ppu

    x, y, angle = track.start_pose
    heading = angle + math.pi / 2
    _arrow(image, to_pixels(x, y), (math.cos(heading), -math.sin(heading)), 40)
    lines = [
        f"procedural track, seed {seed}",
        f"{len(track.tiles)} tiles, {len(track.kerbs)} kerbs",
    ]
    _legend(image, [(None, text) for text in lines] + [(SPAWN_COLOR, "start (tile 0)")])
    return image


def image_picture(config: EnvConfig, track: ImageTrack) -> np.ndarray:
    """The track image with the trajectory drawn back, spawns as arrows, and a colour legend."""
    width, height = track.size
    scale = min(1.0, MAX_SIDE / max(width, height))
    rgb = cv2.cvtColor(track.image, cv2.COLOR_RGBA2RGB)
    cte = config.reward_design.cross_track_error
    if track.trajectory_mask is not None:
        xs, ys = track.trajectory_mask[:, 0], track.trajectory_mask[:, 1]
        rgb[ys, xs] = cte.trajectory_color
    size = (max(1, round(width * scale)), max(1, round(height * scale)))
    image = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA) if scale < 1 else rgb
    for j, (x, y, heading) in enumerate(track.spawns):
        tip = _arrow(image, (x * scale, y * scale), (math.cos(heading), math.sin(heading)), 40)
        cv2.putText(
            image, str(j), (int(tip[0]) + 4, int(tip[1])), _FONT, 0.6, SPAWN_COLOR, 2, cv2.LINE_AA
        )
    entries = [
        (o.color, f"obstacle {o.color!r}: {o.reward}") for o in config.reward_design.color_obstacles
    ]
    if track.trajectory_mask is not None:
        entries.append((cte.trajectory_color, f"trajectory {cte.trajectory_color!r}"))
    entries.append((SPAWN_COLOR, "spawns (index, heading)"))
    _legend(image, entries)
    return image


def metric_picture(track: MetricTrack, texture: GroundTexture) -> np.ndarray:
    """A track in metres, north up: the road or map, cones, the reference line, the start."""
    x0, y0, x1, y1 = track.bounds
    scale = MAX_SIDE / max(x1 - x0, y1 - y0)  # [px/m]
    size = (max(round((x1 - x0) * scale), 1), max(round((y1 - y0) * scale), 1))
    matrix = np.array([[scale, 0.0, -x0 * scale], [0.0, -scale, y1 * scale]])
    image = texture.warp(matrix, size)
    entries: list = [(None, f"{track.kind} track, {(x1 - x0):.0f} x {(y1 - y0):.0f} m")]
    if track.circuit is not None:
        line = transform_points(matrix, np.vstack((track.centerline, track.centerline[:1])))
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
    x, y, heading = track.spawn
    start = transform_points(matrix, np.array([x, y]))
    _arrow(image, (start[0], start[1]), (math.cos(heading), -math.sin(heading)), 40)
    entries.append((SPAWN_COLOR, "start, facing the direction of travel"))
    _legend(image, entries)
    return image


def _arrow(
    image: np.ndarray, start: tuple[float, float], direction: tuple[float, float], length: float
):
    tip = (start[0] + direction[0] * length, start[1] + direction[1] * length)
    cv2.circle(image, (round(start[0]), round(start[1])), 5, SPAWN_COLOR, -1, cv2.LINE_AA)
    p0, p1 = (round(start[0]), round(start[1])), (round(tip[0]), round(tip[1]))
    cv2.arrowedLine(image, p0, p1, SPAWN_COLOR, 2, cv2.LINE_AA, tipLength=0.3)
    return tip


def _legend(image: np.ndarray, entries: list) -> None:
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
