"""Where the cars of an episode start: one at the spawn, or a grid behind it.

The grid's places are laid back along the track's reference line from the spawn (the
pole position at the spawn, each next place ``spacing`` further back, the places
alternating left and right of the line: two staggered columns). The line is the track's
centreline, else its drawn trajectory (picture tracks: walked back pixel by pixel), else
a straight line behind the spawn along its heading. Each place is checked (``fits``):
one where a car would stand on a wall, a cone, an obstacle colour or another car, or
outside the track, is left empty and the car takes the next. Distances are in car
lengths and widths, so that one config fits tracks in any unit.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Hashable, Sequence

import numpy as np

from tinyrace.tracks.base import Pose, Track

PLACES_PER_CAR = 3  # grid places tried per car before the grid gives up on clear ones
Fits = Callable[[int, Pose], bool]  # whether car k may start at a pose (given those placed)
# grids already laid on a track (fixed tracks serve many resets), by the cars' key and knobs
_GRIDS: weakref.WeakKeyDictionary[Track, dict[Hashable, list[Pose]]] = weakref.WeakKeyDictionary()


def grid_poses(
    track: Track,
    spawn: Pose,
    count: int,
    size: tuple[float, float],
    spacing: float,
    offset: float,
    fits: Fits | None = None,
    cars: Hashable = None,
) -> list[Pose]:
    """``count`` start poses: ``spawn`` first (unchanged for one car), then the grid's
    places behind it, each ``spacing`` car lengths behind the one before along the
    reference line and ``offset`` car widths to the left (even places) or right (odd
    places) of it. ``fits(k, pose)``: whether car ``k`` may start there (with cars
    ``0..k-1`` placed); a place that does not fit is skipped. When too few places fit,
    the rest are the next places unchecked (the start's check then names the car).
    Raises ValueError when the grid is longer than the reference line (it would wrap).
    ``size``: (length, width) [track units]. ``cars``: a key of the cars ``fits`` judges;
    given, the grid is kept for the next call with the same track, cars and knobs."""
    if count == 1:
        return [spawn]
    kept = _GRIDS.setdefault(track, {}) if cars is not None else {}
    key = (cars, spawn, count, size, spacing, offset)
    if key not in kept:
        kept[key] = _lay_grid(track, spawn, count, size, spacing, offset, fits)
    return list(kept[key])


def _lay_grid(
    track: Track,
    spawn: Pose,
    count: int,
    size: tuple[float, float],
    spacing: float,
    offset: float,
    fits: Fits | None,
) -> list[Pose]:
    tries = count * PLACES_PER_CAR if fits else count
    if has_line(track):  # the grid stays behind the pole: no place wraps round the loop
        assert track.centerline is not None
        loop, step = line_length(track.centerline), spacing * size[0]
        if (count - 1) * step >= loop:
            raise ValueError(
                f"{count} cars {spacing:g} car lengths apart need {(count - 1) * step:.1f} "
                f"track units of the reference line behind the pole; it is {loop:.1f} long"
            )
        tries = min(tries, math.ceil(loop / step))
    places = grid_places(track, spawn, tries, size, spacing, offset)
    poses: list[Pose] = []
    unused = []
    for pose in places:
        if len(poses) == count:
            break
        if fits is None or fits(len(poses), pose):
            poses.append(pose)
        else:
            unused.append(pose)
    return poses + unused[: count - len(poses)]


def grid_places(
    track: Track,
    spawn: Pose,
    count: int,
    size: tuple[float, float],
    spacing: float,
    offset: float,
) -> list[Pose]:
    """The grid's first ``count`` places (see ``grid_poses``): the pole is the spawn moved
    to its column."""
    length, width = size
    distances = [k * spacing * length for k in range(count)]  # [track units] behind the pole
    sides = [offset * width * (1.0 if k % 2 == 0 else -1.0) for k in range(count)]
    trajectory = track.trajectory_points
    if has_line(track):
        assert track.centerline is not None
        behind = [spawn, *_along_line(track.centerline, spawn, distances)[1:]]  # pole at spawn
    elif trajectory is not None and len(trajectory) >= 2:
        behind = _walk_back(np.asarray(trajectory, np.float64), spawn, distances, length / 4)
    else:
        behind = _straight_back(spawn, distances)
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


def _straight_back(spawn: Pose, distances: Sequence[float]) -> list[Pose]:
    x, y, heading = spawn
    return [(x - d * math.cos(heading), y - d * math.sin(heading), heading) for d in distances]


def _walk_back(
    points: np.ndarray, spawn: Pose, distances: Sequence[float], step: float
) -> list[Pose]:
    """Poses ``distances`` behind ``spawn`` along a line drawn as unordered pixels
    (``points``, (K, 2)): from the spawn, each step goes ``step`` back to the middle of
    the line's pixels about that far ahead of the walk and within 45 degrees of its
    direction; where the line ends, straight on. The spawn is the first pose."""
    x, y, heading = spawn
    here = np.array([x, y])
    direction = -np.array([math.cos(heading), math.sin(heading)])  # backwards
    walked = [(0.0, here, direction)]  # (distance walked, point, direction of the walk)
    travelled, last = 0.0, max(distances)
    while travelled < last:
        offset = points - here
        reach = np.hypot(offset[:, 0], offset[:, 1])
        ahead = offset @ direction
        ring = (np.abs(reach - step) <= step / 2) & (ahead >= reach * math.cos(math.pi / 4))
        if ring.any():
            target = points[ring].mean(axis=0)
            move = target - here
            direction = move / max(float(np.hypot(*move)), 1e-12)
        target = here + step * direction
        travelled += step
        here = target
        walked.append((travelled, here, direction))
    poses = []
    for distance in distances:
        k = min(int(distance // step), len(walked) - 1)
        start, point, _ = walked[k]
        _, _, along = walked[min(k + 1, len(walked) - 1)]
        spot = point + (distance - start) * along
        poses.append((float(spot[0]), float(spot[1]), math.atan2(-along[1], -along[0])))
    return [spawn, *poses[1:]]


def _sideways(pose: Pose, side: float) -> Pose:
    """``pose`` moved ``side`` track units to its left (counter-clockwise of its heading)."""
    x, y, heading = pose
    return (x - side * math.sin(heading), y + side * math.cos(heading), heading)
