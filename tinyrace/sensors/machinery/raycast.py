"""Ray casting on a blocking map: sample tables of a fan of beams, and two vectorised passes.

Built once per track: the map of blocking cells, padded with a border that blocks too (the
edge of the map stops a beam), and NEAR maps: for each of ORIENTATIONS directions, the
cells from which a segment of a beam in that direction, COARSE_STEP long and centred there,
could touch a blocking cell (a dilation of the blocking cells by that segment; one bit per
direction). Built once per lidar and track: a ``Fan``, the flat offsets of every sample of
every beam, for every heading (one table row per angle step) and ORIGIN_STEPS^2 positions
of the origin inside its cell.

A scan takes two gathers, whatever the heading and the walls: a coarse pass samples the
middle of every COARSE_STEP segment of every beam in its direction's NEAR map and finds each
beam's first flagged segment; a fine pass samples that segment every FINE_STEP in the
blocking map and finds the first blocked sample; the range is the middle between it and the
sample before (from the origin rounded to 1 / ORIGIN_STEPS of a cell, the fan turned to the
nearest table row). The first flag of each beam is found by packing its 16 flags into bits
and a lookup table, never a loop over rows. Beams whose flagged segment only passed blocking
cells by (false alarms) go on to their next flagged segment while they are many, and sample
their whole row when few: a few passes, never a loop over beams. Beyond TABLE_RANGE, beams
march on by sphere tracing on a distance field (``cv2.distanceTransform``), built only for
lidars that reach that far.

A field is made for one of two paths: the numpy passes above (``raycast_numpy``;
``near=True``: NEAR maps, and ``beam_fan(..., tables=True)``), or ``kernels/raycast.py``'s
compiled kernel (``near=False``: a skip map from the distance transform, no tables), which
finds the same first blocked sample of every beam and gives the same ranges, bit for bit.
On ROS maps the beams cross the map's cells exactly instead (``raycast_exact``).

Units: the maps work in cells; ``to_cells`` maps track units to cell coordinates (a cell's
centre on integer coordinates, as image pixels) and ranges come back in track units.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

COARSE_STEP = 8  # [cells] length of the segments the coarse pass tests with one sample each
FINE_SAMPLES = 16  # samples per segment in the fine pass (16: two uint64 words per beam)
FINE_STEP = COARSE_STEP / FINE_SAMPLES  # [cells]
ORIENTATIONS = 8  # directions of NEAR maps over half a turn (bits of a uint8)
ORIGIN_STEPS = 3  # origin positions per axis inside a cell that the tables are made for
ANGLE_STEP = math.radians(0.26)  # [rad] largest angle between two rows of a fan's tables
TABLE_RANGE = 120  # [cells] farthest sample of the tables (< 16 segments); beams march on beyond
WORDS = 16  # columns of the coarse table and samples of a fine window: two uint64 words
PAD = COARSE_STEP // 2 + 4  # [cells] blocking border around the map
LEAD = TABLE_RANGE + 2 * COARSE_STEP + PAD + 2  # [rows] around the flat maps: no sample leaves
FAR = 1 << 30  # a table offset past the end of the flat maps (np.take clips it to the end)
MIN_STEP = 1.0  # [cells] smallest sphere-tracing step of a free beam
STEP_CAP = 127.5  # [cells] largest sphere-tracing step (uint8 half cells)
OVERSHOOT = 2.0  # [cells] a marching tip enters a blocking cell less than this far past its edge
BISECTIONS = 3  # rounds that halve the overshoot bracket: error <= OVERSHOOT / 8
CHECK_EVERY = 4  # marching rounds between checks whether every beam has stopped
MAX_ROUNDS = 256  # marching rounds at most
SKIP_BLOCKED = 255  # the skip map's value of blocking cells
SKIP_MARGIN = 1.42  # [cells] > sqrt(2): two samples' distances to their nearest cells' centres
SECTOR_SLOPES = 4  # sector skip maps per eighth of a turn (slopes 0 .. 1 in steps of 1 / 4)
SECTORS = 8 * SECTOR_SLOPES  # sector skip maps of a field (kernels.raycast.with_sectors)


@dataclass(frozen=True, eq=False)
class DistanceField:
    """The blocking map of one track and what the passes sample, padded by PAD cells.

    ``blocked`` (1: blocking), ``near`` (bit o: near in direction o; the numpy passes) and
    ``skips`` (samples a beam can skip; the compiled kernel) are flat uint8 maps with LEAD
    extra rows before and after, so that no table offset leaves them (blocking, all bits
    set, SKIP_BLOCKED; FAR lands on the last one); a field has ``near`` or ``skips``, as
    made for one path or the other. ``steps`` are sphere-tracing steps in half cells (uint8,
    0 in blocking cells, rounded down so that they stay safe, at most STEP_CAP cells), when
    the field was made to reach that far.
    """

    blocked: np.ndarray  # (LEAD * w + H * w + LEAD * w,) uint8, w the padded width
    near: np.ndarray | None  # same layout
    shape: tuple[int, int]  # (H, w) rows and columns of the padded map
    to_cells: np.ndarray  # 2x3 affine: track units -> cell coordinates of the padded map
    cells_per_unit: float  # [cells per track unit]
    steps: np.ndarray | None = None  # (H, w) uint8 [half cells]
    classes: np.ndarray | None = None  # (H, w) uint8 hit class of blocking cells and their rim
    skips: np.ndarray | None = None  # same layout as ``blocked`` [FINE_STEP samples]
    # SECTORS skip maps, one per sector of beam directions, (s H, s w) each (s =
    # ``sector_scale`` cells of theirs per cell and axis), one after the other between
    # s LEAD rows (kernels.raycast.with_sectors) [FINE_STEP samples]
    sectors: np.ndarray | None = None
    sector_scale: int = 1

    def blocking(self) -> np.ndarray:
        """(H, w) uint8 view of the padded map, 1 where blocking."""
        height, width = self.shape
        return self.blocked[LEAD * width : (LEAD + height) * width].reshape(height, width)

    @functools.cached_property
    def affine(self) -> tuple[float, float, float, float, float, float]:
        """``to_cells`` as floats (a, b, c, d, e, f): cells (a x + b y + c, d x + e y + f)."""
        (a, b, c), (d, e, f) = self.to_cells.tolist()
        return a, b, c, d, e, f

    @functools.cached_property
    def frame(self) -> tuple[float, float]:
        """[rad] the angle of the track's x axis in the cell frame, and -1 if the cell frame
        is mirrored (else 1)."""
        a, b, _, d, e, _ = self.affine
        return math.atan2(d, a), -1.0 if a * e < b * d else 1.0

    def cells(self, point: tuple[float, float]) -> tuple[float, float]:
        """[cells] of a track point in the padded map."""
        a, b, c, d, e, f = self.affine
        return a * point[0] + b * point[1] + c, d * point[0] + e * point[1] + f


def distance_field(
    blocking: np.ndarray,
    to_cells: np.ndarray,
    classes: np.ndarray | None = None,
    reach: float = math.inf,
    near: bool = True,
) -> DistanceField:
    """The field of a boolean (H, W) map of blocking cells, ``to_cells`` track -> cell affine;
    ``classes`` (H, W) uint8 hit classes of the blocking cells, when beams report them;
    ``reach`` [cells] the longest range it serves; ``near``: the NEAR maps of the numpy
    passes, else the skip map of the compiled kernel. Outside the map blocks (as a wall)."""
    padded = cv2.copyMakeBorder(
        blocking.astype(np.uint8), PAD, PAD, PAD, PAD, cv2.BORDER_CONSTANT, value=1
    )
    width = padded.shape[1]
    lead = np.ones(LEAD * width, np.uint8)
    blocked = np.concatenate([lead, padded.ravel(), lead])
    distance = distance_map(padded) if reach > TABLE_RANGE or not near else None
    steps = _steps(distance) if reach > TABLE_RANGE and distance is not None else None
    near_maps = skips = None
    if near:
        near_maps = np.concatenate([lead * 255, _near(padded).ravel(), lead * 255])
    else:
        assert distance is not None
        skips = _skips(distance)  # the distances are gone: steps first
        skips = np.concatenate([lead * SKIP_BLOCKED, skips.ravel(), lead * SKIP_BLOCKED])
    shifted = np.asarray(to_cells, np.float64) + np.array([[0, 0, PAD], [0, 0, PAD]])
    scale = math.sqrt(abs(np.linalg.det(shifted[:, :2])))
    if classes is not None:  # an end may stop a rounding error short: the rim has the class too
        classes = cv2.copyMakeBorder(classes, PAD, PAD, PAD, PAD, cv2.BORDER_CONSTANT, value=1)
        classes = np.where(classes > 0, classes, cv2.dilate(classes, np.ones((3, 3), np.uint8)))
    shape = padded.shape
    return DistanceField(blocked, near_maps, shape, shifted, scale, steps, classes, skips)


def _near(padded: np.ndarray) -> np.ndarray:
    """uint8 NEAR maps of a padded blocking map: bit o set where a segment in direction o
    could touch a blocking cell."""
    near = np.zeros_like(padded)
    for o in range(ORIENTATIONS):
        dilated: np.ndarray = cv2.dilate(padded, _segment_kernel(o))
        np.bitwise_or(near, np.left_shift(dilated, o), out=near)
    return near


@functools.cache
def _segment_kernel(orientation: int) -> np.ndarray:
    """uint8 kernel: the cell offsets (x, y) within half a cell's diagonal, twice, of a
    segment COARSE_STEP long centred on 0 in a direction within half an orientation step of
    ``orientation`` (the sample's nearest cell and the blocking cell each add one)."""
    r = math.ceil(COARSE_STEP / 2 + math.sqrt(2))
    y, x = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float64)
    half = math.pi / ORIENTATIONS / 2
    centre = orientation * math.pi / ORIENTATIONS
    distance = np.full(x.shape, np.inf)
    for a in np.linspace(centre - half, centre + half, 33):
        along = np.clip(x * math.cos(a) + y * math.sin(a), -COARSE_STEP / 2, COARSE_STEP / 2)
        distance = np.minimum(distance, np.hypot(x - along * math.cos(a), y - along * math.sin(a)))
    kernel: np.ndarray = (distance <= math.sqrt(2) + 1e-6).astype(np.uint8)
    return kernel


def distance_map(padded: np.ndarray) -> np.ndarray:
    """float32 [cells] from each cell's centre to the nearest blocking cell's centre (exact
    Euclidean), 0 in blocking cells."""
    free = np.where(padded > 0, np.uint8(0), np.uint8(255))
    distance: np.ndarray = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return distance


def _steps(distance: np.ndarray) -> np.ndarray:
    """Sphere-tracing steps [half cells] of a padded blocking map of ``distance``es [cells]:
    a free cell's centre's distance to the nearest blocking cell's centre less half a cell,
    at least MIN_STEP."""
    steps: np.ndarray = np.floor(2 * np.clip(distance - 0.5, MIN_STEP, STEP_CAP)).astype(np.uint8)
    steps[distance == 0] = 0
    return steps


def _skips(distance: np.ndarray) -> np.ndarray:
    """uint8 samples (FINE_STEP apart) that a beam whose sample is nearest to a cell may
    skip, from ``distance`` [cells] to the nearest blocking cell: n such that n FINE_STEPs
    plus both samples' rounding to their nearest cells (half a diagonal each, SKIP_MARGIN
    with room for float error) stay short of it; SKIP_BLOCKED in blocking cells. Works in
    ``distance`` (float32), which it overwrites."""
    blocking = distance == 0
    np.subtract(distance, SKIP_MARGIN, out=distance)
    np.divide(distance, FINE_STEP, out=distance)
    np.floor(distance, out=distance)
    np.clip(distance, 0, SKIP_BLOCKED - 1, out=distance)
    skips = distance.astype(np.uint8)
    skips[blocking] = SKIP_BLOCKED
    return skips


@dataclass(frozen=True, eq=False)
class Fan:
    """Sample tables of evenly spaced beams on one field, for every heading.

    Rows are angles ``step`` apart in the cell frame, ``spacing`` rows between neighbouring
    beams, stored phase by phase so that the rows of one scan are contiguous. Offsets are
    flat indices relative to the origin's cell plus LEAD rows.
    """

    # offsets are intp: np.take converts other index types first, at a cost; None when the
    # fan was made without them (the compiled kernel computes the same offsets per beam)
    coarse: np.ndarray | None  # (V, rows, WORDS) intp: segment middles, then FAR
    fine: np.ndarray | None  # (V, rows, (segments + 2) * FINE_SAMPLES) intp: samples along
    #                          a row, the last FINE_SAMPLES FAR
    ranges: np.ndarray  # ((segments + 2) * FINE_SAMPLES,) float32 [track units] per sample
    #                     (the middle between it and the previous one, at most max_range);
    #                     past the tables: inf (sphere tracing goes on) or max_range
    found: np.ndarray  # ((segments + 1) * (FINE_SAMPLES + 1),) float32 [track units] by
    #                    segment and first hit in its window: ``ranges``, then -1 for none
    bits: np.ndarray  # (rows, WORDS) uint8 the NEAR bit of each row's direction
    cos: np.ndarray  # (rows,) float64 direction of each row [cells]
    sin: np.ndarray
    sectors: np.ndarray  # (rows,) int64 the sector of each row's direction (``sector``)
    shifts: np.ndarray  # (ORIGIN_STEPS,) float64 [cells] origin positions inside a cell
    beam_windows: np.ndarray  # (beams,) int: i * (segments + 2), beam i's first window
    beam_samples: np.ndarray  # (beams,) int: i * FINE_SAMPLES
    anchor: float  # [rad] angle of the row 0
    step: float  # [rad] between rows
    spacing: int  # rows between neighbouring beams
    phase_rows: int  # rows per phase
    beams: int
    segments: int  # in the tables
    table_range: float  # [cells] how far the tables reach
    limit: float  # [cells] max range
    max_range: float  # [track units]


def beam_fan(
    field: DistanceField,
    angles: np.ndarray,
    max_range: float,
    y_down: bool = False,
    tables: bool = True,
) -> Fan:
    """The tables of beams at evenly spaced ``angles`` [rad], ascending, reaching
    ``max_range`` [track units] on ``field`` (of a y-down track: ``y_down``). The rows are
    placed so that a car at heading 0 gets its beams without turning them. ``tables``: build
    the offset tables that ``cast`` gathers with (most of a fan's memory); the compiled
    kernel (``kernels/raycast.py``) needs only the rows' directions."""
    beams = len(angles)
    spacing, step, phase_rows = _rows(angles)
    phase, u = np.divmod(np.arange(spacing * phase_rows), phase_rows)
    anchor = fan_angle(field, angles, 0.0, y_down)[0]
    angle = anchor + (u * spacing + phase) * step  # row -> its angle, phase-major
    limit = max_range * field.cells_per_unit
    table_range = min(limit, TABLE_RANGE)
    segments = max(1, math.ceil(table_range / COARSE_STEP - 1e-9))
    width = field.shape[1]
    middles = (np.arange(segments) + 0.5) * COARSE_STEP  # [cells]
    radii = np.arange(1, (segments + 1) * FINE_SAMPLES + 1) * FINE_STEP  # [cells]
    shifts = (np.arange(ORIGIN_STEPS) + 0.5) / ORIGIN_STEPS - 0.5  # [cells] in the cell
    c, s = np.cos(angle), np.sin(angle)
    coarse, fine = [], []
    for sx in shifts if tables else ():
        for sy in shifts:
            middle = _flat(sx + c[:, None] * middles, sy + s[:, None] * middles, width)
            far = np.full((len(c), WORDS - segments), FAR, np.intp)
            coarse.append(np.concatenate([middle, far], 1))
            samples = _flat(sx + c[:, None] * radii, sy + s[:, None] * radii, width)
            fine.append(np.concatenate([samples, np.full((len(c), FINE_SAMPLES), FAR)], 1))
    past = np.inf if table_range < limit else max_range  # [track units] past the tables
    ranges = np.full((segments + 2) * FINE_SAMPLES, past)
    middles_units = (radii[: segments * FINE_SAMPLES] - FINE_STEP / 2) / field.cells_per_unit
    ranges[: segments * FINE_SAMPLES] = np.minimum(middles_units, past)
    ranges = ranges.astype(np.float32)
    found = np.full((segments + 1, FINE_SAMPLES + 1), -1.0, np.float32)
    found[:, :-1] = ranges[: (segments + 1) * FINE_SAMPLES].reshape(segments + 1, -1)
    found[-1] = past
    orientation = np.rint(angle / (math.pi / ORIENTATIONS)).astype(np.int64) % ORIENTATIONS
    bits = np.repeat((1 << orientation).astype(np.uint8)[:, None], WORDS, 1)
    return Fan(
        np.stack(coarse) if tables else None, np.stack(fine) if tables else None,
        ranges, found.ravel(), bits, c, s, sector(c, s), shifts,
        np.arange(beams) * (segments + 2), np.arange(beams) * FINE_SAMPLES,
        anchor, step, spacing, phase_rows, beams, segments, table_range, limit, max_range,
    )  # fmt: skip


def sector(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """int64 sector of the directions (c, s) [cells]: its eighth of a turn (bit 0: c < 0,
    bit 1: s < 0, bit 2: |s| > |c|) times SECTOR_SLOPES plus the step of its slope (the
    minor over the major component, 0 .. 1 in SECTOR_SLOPES steps). Its directions' slopes
    lie in [step, step + 1] / SECTOR_SLOPES (up to rounding)."""
    swap = np.abs(s) > np.abs(c)
    slope = np.minimum(np.abs(c), np.abs(s)) / np.maximum(np.abs(c), np.abs(s))
    step = np.minimum((slope * SECTOR_SLOPES).astype(np.int64), SECTOR_SLOPES - 1)
    eighth = (c < 0).astype(np.int64) + 2 * (s < 0) + 4 * swap
    sectors: np.ndarray = eighth * SECTOR_SLOPES + step
    return sectors


def _rows(angles: np.ndarray) -> tuple[int, float, int]:
    """A fan's rows for beams at evenly spaced ``angles`` [rad]: (rows between neighbouring
    beams, angle between rows [rad], rows per phase)."""
    beams = len(angles)
    spread = float(angles[1] - angles[0]) if beams > 1 else ANGLE_STEP
    assert beams == 1 or np.allclose(np.diff(angles), spread), "evenly spaced beams"
    spacing = max(1, math.ceil(spread / ANGLE_STEP - 1e-9))
    step = spread / spacing
    count = math.ceil(2 * math.pi / step) + 1 + spacing * (beams - 1)  # angles j * step
    return spacing, step, math.ceil(count / spacing)


def table_bytes(angles: np.ndarray) -> int:
    """[bytes] the offset tables of a fan of beams at ``angles`` [rad] take at most (tables
    that reach TABLE_RANGE). They grow as one over the angle between beams: 1080 beams over
    270 deg take about 50 MB, over 1 deg several GB."""
    spacing, _, phase_rows = _rows(angles)
    segments = math.ceil(TABLE_RANGE / COARSE_STEP - 1e-9)
    per_row = WORDS + (segments + 2) * FINE_SAMPLES  # coarse, then fine offsets
    return ORIGIN_STEPS**2 * spacing * phase_rows * per_row * np.dtype(np.intp).itemsize


def _flat(x: np.ndarray, y: np.ndarray, width: int) -> np.ndarray:
    """intp flat offsets (plus LEAD rows) of the cells nearest to offsets x, y [cells]."""
    return (np.floor(y + 0.5) * width + np.floor(x + 0.5) + LEAD * width).astype(np.intp)


class Start(NamedTuple):
    """Where a scan starts in a fan's tables (a tuple: made on every scan)."""

    x: float  # [cells] the origin in the padded map
    y: float
    base: int  # flat index of the origin's cell in the padded map (without LEAD rows)
    vx: int  # the origin's position inside its cell, 0 .. ORIGIN_STEPS - 1 per axis
    vy: int
    top: int  # the table row of the first beam


def start(
    field: DistanceField, fan: Fan, origin: tuple[float, float], first: float
) -> Start | None:
    """Where a scan of ``fan`` from ``origin`` [track units], the first beam at angle
    ``first`` [rad] in the cell frame, starts; None when the origin is in a blocking cell or
    off the map. The origin rounds to 1 / ORIGIN_STEPS of a cell, the fan to the nearest
    row."""
    x, y = field.cells(origin)
    col, row = math.floor(x + 0.5), math.floor(y + 0.5)
    height, width = field.shape
    base = row * width + col
    if not (0 <= row < height and 0 <= col < width) or field.blocked[LEAD * width + base]:
        return None
    vx = min(int((x + 0.5 - col) * ORIGIN_STEPS), ORIGIN_STEPS - 1)
    vy = min(int((y + 0.5 - row) * ORIGIN_STEPS), ORIGIN_STEPS - 1)
    j = round(((first - fan.anchor) % (2 * math.pi)) / fan.step)
    top = (j % fan.spacing) * fan.phase_rows + j // fan.spacing  # the first beam's row
    return Start(x, y, base, vx, vy, top)


def fan_angle(
    field: DistanceField, angles: np.ndarray, heading: float, y_down: bool
) -> tuple[float, bool]:
    """The cell-frame angle [rad] that ``cast`` starts a fan of ``angles`` [rad, + left] at,
    from a car at ``heading`` [rad] (counter-clockwise on y-up tracks, clockwise on y-down
    image tracks), and whether the beams then come out last first."""
    turn, mirror = field.frame
    sign = mirror * (-1.0 if y_down else 1.0)  # cell angle = turn + mirror * heading + sign * a
    reverse = sign < 0
    first = float(angles[-1] if reverse else angles[0])
    return turn + mirror * heading + sign * first, reverse
