"""The track under each episode, saved once per track as a picture with its world-to-pixel
frame, start and lap line: what the report draws trajectories over."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2

from tinyrace.env import TinyRaceEnv
from tinyrace.experiment.files import write_file
from tinyrace.render.track_picture import ground_picture


def save_track_picture(
    env: TinyRaceEnv, seed: int, run_dir: Path, known: dict[str, dict[str, Any]]
) -> tuple[str, dict[str, Any]]:
    """(key, entry) of the env's current track; writes ``track_<key>.png`` the first time.

    A track made anew at each reset (procedural) differs per seed; fixed tracks per track
    index. The entry holds the picture's file, ``frame`` (sx, ox, sy, oy: px = x * sx + ox,
    py = y * sy + oy), the start pose, the lap line (two points: where tile 0 begins) on
    tracks with tiles, and the track's unit.
    """
    episode = env.episode
    assert episode is not None, "reset() first"
    track = episode.track
    key = f"seed{seed}" if track.drawn_per_reset else f"track{episode.track_index}"
    if key in known:
        return key, known[key]
    image, frame = ground_picture(env.config, track, lambda: env.ground.texture(track))
    start = track.spawns[episode.spawn_index]
    tiles = track.tiles
    lap_line = None if tiles is None or not len(tiles) else tiles[0][:2].tolist()
    name = f"track_{key}.png"
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 picture
        raise ValueError(f"cannot encode the track picture {name}")
    write_file(run_dir / name, data.tobytes())
    entry = {
        "image": name,
        "frame": [frame.sx, frame.ox, frame.sy, frame.oy],
        "start": [float(v) for v in start[:2]],
        "lap_line": lap_line,
        "unit": track.unit,
    }
    return key, entry
