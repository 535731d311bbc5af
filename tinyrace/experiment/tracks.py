"""The track under each episode, saved once per track as a picture with its world-to-pixel
frame, start and lap line: what the report draws trajectories over."""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

import cv2

from tinyrace.config import METRIC_KINDS, ProceduralTrackConfig
from tinyrace.env import TinyRaceEnv
from tinyrace.render.track_picture import image_ground, metric_ground, procedural_ground


def save_track_picture(
    env: TinyRaceEnv, seed: int, run_dir: Path, known: dict[str, dict[str, Any]]
) -> tuple[str, dict[str, Any]]:
    """(key, entry) of the env's current track; writes ``track_<key>.png`` the first time.

    Procedural tracks differ per seed; image tracks per track index. The entry holds the
    picture's file, ``frame`` (sx, ox, sy, oy: px = x * sx + ox, py = y * sy + oy), the
    start pose and, on procedural tracks, the lap line (two points) in track units.
    """
    episode: Any = env.episode
    ground: Any = env.ground  # its colours (procedural) and ground texture
    procedural = env.config.kind == "procedural"
    key = f"seed{seed}" if procedural else f"track{episode.track_index}"
    if key in known:
        return key, known[key]
    if procedural:
        track = episode.track.detail
        playfield = cast(ProceduralTrackConfig, env.config.tracks[0]).playfield  # [u]
        image, frame = procedural_ground(track, ground.colors, playfield)
        start = track.start_pose
        lap_line = track.tiles[0][:2].tolist()  # the edge where tile 0 begins
    elif env.config.kind in METRIC_KINDS:
        track = episode.track.detail
        image, frame = metric_ground(track, ground.texture(episode.track))
        start = track.spawn
        lap_line = None if track.circuit is None else track.tiles[0][[0, 1]].tolist()
    else:
        image, frame = image_ground(env.config, episode.track.detail)
        start, lap_line = episode.track.spawns[episode.spawn_index], None
    name = f"track_{key}.png"
    cv2.imwrite(str(run_dir / name), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    entry = {
        "image": name,
        "frame": [frame.sx, frame.ox, frame.sy, frame.oy],
        "start": [float(v) for v in start[:2]],
        "lap_line": lap_line,
        "unit": "u" if procedural else ("m" if env.config.kind in METRIC_KINDS else "px"),
    }
    return key, entry
