"""Where the cars of an episode start: one at the spawn, or a grid behind it.

The grid follows the track's reference line backwards from the spawn when the track has
one (the pole position at the spawn, each next car ``spacing`` further back, the cars
alternating left and right of the line), else a straight line behind the spawn along
its heading. Distances are in car lengths and widths, so that one config fits tracks in
any unit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tinyrace.tracks.base import Pose, Track


def grid_poses(
    track: Track,
    spawn: Pose,
    count: int,
    size: tuple[float, float],
    spacing: float,
    offset: float,
) -> list[Pose]:
    """``count`` start poses: ``spawn`` first (unchanged for one car), then each car
    ``spacing`` car lengths behind the one before, ``offset`` car widths to the left
    (even places) or right (odd places) of the line. ``size``: (length, width) [track units].
    Raises ValueError when the grid is longer than the reference line (it would wrap)."""
    if count == 1:
        return [spawn]
    length, width = size
    distances = [k * spacing * length for k in range(count)]  # [track units] behind the pole
    sides = [offset * width * (1.0 if k % 2 == 0 else -1.0) for k in range(count)]
    if has_line(track):
        assert track.centerline is not None
        loop = line_length(track.centerline)
        if distances[-1] >= loop:  # the last car would wrap round onto the cars ahead
            raise ValueError(
                f"{count} cars {spacing:g} car lengths apart need {distances[-1]:.1f} track "
                f"units of the reference line behind the pole; it is {loop:.1f} long"
            )
        behind = [spawn, *_along_line(track.centerline, spawn, distances)[1:]]  # pole at spawn
    else:
        x, y, heading = spawn
        behind = [
            (x - d * math.cos(heading), y - d * math.sin(heading), heading) for d in distances
        ]
    return [_sideways(pose, side) for pose, side in zip(behind, sides, strict=True)]


def random_poses(
    track: Track,
    spawn: Pose,
    count: int,
    size: tuple[float, float],
    gap: float,
    offset: float,
    rng: np.random.Generator,
) -> list[Pose]:
    """``count`` start poses at random places along the track's reference line, each at
    least ``gap`` car lengths from the next along the line and up to ``offset`` car widths
    to either side; on a track without a line, the grid's places in a random order.
    Raises ValueError when the line is too short for ``count`` cars so far apart."""
    if not has_line(track):
        places = grid_poses(track, spawn, count, size, gap, offset)
        return [places[i] for i in rng.permutation(count)]
    assert track.centerline is not None
    length, width = size
    loop = line_length(track.centerline)
    room = loop - count * gap * length  # [track units] free of the gaps between the cars
    if room < 0:
        raise ValueError(
            f"{count} cars {gap:g} car lengths apart need {count * gap * length:.1f} track "
            f"units of the reference line; it is {loop:.1f} long"
        )
    starts = np.sort(rng.uniform(0.0, room, count)) + gap * length * np.arange(count)
    distances = (starts + rng.uniform(0.0, loop)) % loop  # [track units] behind the spawn
    sides = rng.uniform(-offset * width, offset * width, count)
    poses = _along_line(track.centerline, spawn, distances.tolist())
    return [_sideways(pose, float(side)) for pose, side in zip(poses, sides, strict=True)]


def has_line(track: Track) -> bool:
    """Whether the track has a reference line to place cars along."""
    return track.centerline is not None and len(track.centerline) >= 3


def line_length(points: np.ndarray) -> float:
    """[track units] round the closed polyline ``points``."""
    loop = np.asarray(points, dtype=np.float64)
    steps = np.diff(np.concatenate([loop, loop[:1]]), axis=0)
    return float(np.hypot(steps[:, 0], steps[:, 1]).sum())


def _along_line(points: np.ndarray, spawn: Pose, distances: Sequence[float]) -> list[Pose]:
    """Poses on the closed polyline ``points`` at ``distances`` behind the point nearest
    ``spawn``, facing the direction of travel (the spawn's own heading decides which)."""
    x, y, heading = spawn
    loop = np.asarray(points, dtype=np.float64)
    start = int(np.argmin(np.hypot(loop[:, 0] - x, loop[:, 1] - y)))
    ahead = loop[(start + 1) % len(loop)] - loop[start]
    forward = ahead[0] * math.cos(heading) + ahead[1] * math.sin(heading) >= 0
    order = np.roll(loop, -start, axis=0)  # the spawn's nearest point first
    if forward:  # walking backwards means walking the points in reverse
        order = np.concatenate([order[:1], order[:0:-1]])
    steps = np.diff(np.concatenate([order, order[:1]]), axis=0)
    reach = np.concatenate([[0.0], np.cumsum(np.hypot(steps[:, 0], steps[:, 1]))])
    poses = []
    for distance in distances:
        d = distance % reach[-1]
        i = min(int(np.searchsorted(reach, d, side="right")) - 1, len(order) - 1)
        t = (d - reach[i]) / max(reach[i + 1] - reach[i], 1e-12)
        px, py = order[i] + t * steps[i]
        back = math.atan2(steps[i][1], steps[i][0])  # the walk's direction: against travel
        poses.append((float(px), float(py), back + math.pi))
    return poses


def _sideways(pose: Pose, side: float) -> Pose:
    """``pose`` moved ``side`` track units to its left (counter-clockwise of its heading)."""
    x, y, heading = pose
    return (x - side * math.sin(heading), y + side * math.cos(heading), heading)
