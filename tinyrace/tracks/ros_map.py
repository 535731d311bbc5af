"""The ROS map_server occupancy map (used by F1TENTH): a YAML file beside a picture.

YAML keys: ``image`` (relative to the YAML), ``resolution`` [m/px], ``origin``
[x m, y m, yaw rad] (the pose of the image's lower-left pixel), ``negate``,
``occupied_thresh``, ``free_thresh`` and an optional ``mode``. In ``trinary`` (the
default) and ``scale`` modes a pixel of value v has occupancy p = (255 - v) / 255 (v / 255
when negated): occupied above ``occupied_thresh``, free below ``free_thresh``, between
unknown (trinary) or a cost (scale), either way not drivable; a picture's alpha is not
read. In ``raw`` mode the value is the occupancy in percent, as map_server reads it (0-100,
``negate`` not applied; above 100 unknown), against the same thresholds. Image row 0 is
the top; world y grows upward.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TypeGuard

import cv2
import numpy as np
import yaml

from tinyrace.config.bounds import (
    MAX_COORDINATE,
    MAX_MAP_WALLS,
    MIN_MAP_SIDE,
    RESOLUTION_RANGE,
)
from tinyrace.config.image_file import read_image_bgr
from tinyrace.config.paths import inside_folder
from tinyrace.config.schema import FilesConfig
from tinyrace.config.yaml_file import parse_yaml
from tinyrace.errors import ConfigError, Problem, shown
from tinyrace.tracks.csv_rows import read_text

MODES = ("trinary", "scale", "raw")
DEFAULT_FILES = FilesConfig()


@dataclass(frozen=True)
class MapInfo:
    """The YAML's numbers: where the picture sits in the world and how to read it."""

    image: Path  # the picture, resolved
    resolution: float  # [m/px]
    origin: tuple[float, float, float]  # [m, m, rad] pose of the lower-left pixel's corner
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str = "trinary"  # one of MODES


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """Free and occupied cells of a map, and the transform between world and pixels."""

    info: MapInfo
    free: np.ndarray  # (H, W) bool: drivable
    occupied: np.ndarray  # (H, W) bool: walls

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        return self.free.shape

    def to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(K, 2) world points [m] of the centres of pixels (row, col)."""
        height = self.free.shape[0]
        local = self.info.resolution * np.column_stack(
            (np.asarray(cols) + 0.5, height - np.asarray(rows) - 0.5)
        )
        return np.asarray(_rotate(local, self.info.origin[2]) + self.info.origin[:2], float)

    def to_pixel(self, points: np.ndarray) -> np.ndarray:
        """(K, 2) fractional (row, col) of world points [m]; inverse of ``to_world``."""
        local = _rotate(np.asarray(points, float) - self.info.origin[:2], -self.info.origin[2])
        cols = local[:, 0] / self.info.resolution - 0.5
        rows = self.free.shape[0] - local[:, 1] / self.info.resolution - 0.5
        return np.column_stack((rows, cols))

    def to_cells(self) -> np.ndarray:
        """2x3 affine: world point [m] -> fractional (col, row) of the picture, pixel centres
        on integer coordinates (``to_pixel``'s columns and rows as one matrix); a pixel is
        the square of side 1 around its centre, its edges on half-integer coordinates."""
        res, (ox, oy, yaw) = self.info.resolution, self.info.origin
        c, s = math.cos(yaw), math.sin(yaw)
        height = self.free.shape[0]
        return np.array(
            [
                [c / res, s / res, -(c * ox + s * oy) / res - 0.5],
                [s / res, -c / res, height - 0.5 + (c * oy - s * ox) / res],
            ]
        )

    def is_free(self, points: np.ndarray) -> np.ndarray:
        """(K,) bool: whether each world point [m] lies on a free cell (outside: not free)."""
        rows, cols, inside = self._cells_of(points)
        result = np.zeros(len(rows), bool)
        result[inside] = self.free[rows[inside], cols[inside]]
        return result

    def on_map(self, points: np.ndarray) -> np.ndarray:
        """(K,) bool: whether each world point [m] lies on a cell of the map."""
        return self._cells_of(points)[2]

    def _cells_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The nearest cell's row and column of each world point [m], and whether it is one
        of the map's."""
        pixel = np.rint(self.to_pixel(points)).astype(int)
        rows, cols = pixel[:, 0], pixel[:, 1]
        inside = (rows >= 0) & (rows < self.shape[0]) & (cols >= 0) & (cols < self.shape[1])
        return rows, cols, inside

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """(K,) [m] distance from each world point to the nearest cell that is not free."""
        field = cv2.distanceTransform(self.free.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_5)
        pixel = np.rint(self.to_pixel(points)).astype(int)
        rows = np.clip(pixel[:, 0], 0, self.shape[0] - 1)
        cols = np.clip(pixel[:, 1], 0, self.shape[1] - 1)
        return np.asarray(field[rows, cols] * self.info.resolution, float)

    def wall_segments(self, tolerance_px: float = 1.0) -> np.ndarray:
        """(M, 2, 2) [m] the outlines of the occupied regions as line segments, simplified
        to within ``tolerance_px`` pixels (pymunk walls: few shapes, solid from outside)."""
        contours, _ = cv2.findContours(
            self.occupied.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE
        )
        segments = []
        for contour in contours:
            outline = cv2.approxPolyDP(contour, tolerance_px, True)[:, 0, :]  # (K, 2) col, row
            world = self.to_world(outline[:, 1], outline[:, 0])
            if len(world) == 1:
                world = np.vstack((world, world))
            segments.append(np.stack((world, np.roll(world, -1, axis=0)), axis=1))
        return np.concatenate(segments) if segments else np.zeros((0, 2, 2))

    @functools.cached_property
    def rects(self) -> np.ndarray:
        """(M, 4) int the occupied pixels as rectangles (``pixel_rects``), found once."""
        return pixel_rects(self.occupied)

    def wall_quads(self) -> np.ndarray:
        """(M, 4, 2) [m] the occupied pixels as solid walls for the physics: rectangles of
        whole pixels (``pixel_rects``), each the four corners of its pixels' outer edges in
        the world (counter-clockwise; turned with the origin's yaw). Their union is the
        occupied pixels exactly: no wall reaches past an occupied pixel."""
        rects = self.rects.astype(np.float64)
        if len(rects) == 0:
            return np.zeros((0, 4, 2))
        top, left = rects[:, 0] - 0.5, rects[:, 1] - 0.5  # pixel edges: centres +- 0.5
        bottom, right = rects[:, 2] + 0.5, rects[:, 3] + 0.5
        rows = np.stack((bottom, bottom, top, top), axis=1).ravel()  # image rows grow down
        cols = np.stack((left, right, right, left), axis=1).ravel()
        return self.to_world(rows, cols).reshape(-1, 4, 2)


def pixel_rects(mask: np.ndarray) -> np.ndarray:
    """(M, 4) int rectangles first row, first column, last row, last column (inclusive)
    that cover the True pixels of ``mask`` exactly, without overlap: each row's runs of
    True pixels, a run merged with the same run on the rows below. Runs are taken along
    rows or along columns, whichever gives fewer rectangles."""
    by_rows = _merged_runs(mask)
    by_cols = _merged_runs(mask.T)[:, [1, 0, 3, 2]]
    return by_rows if len(by_rows) <= len(by_cols) else by_cols


def _merged_runs(mask: np.ndarray) -> np.ndarray:
    h, w = mask.shape
    padded = np.zeros((h, w + 2), np.int8)
    padded[:, 1:-1] = mask
    step = np.diff(padded, axis=1)
    rows, first = np.nonzero(step == 1)
    if not len(rows):  # no True pixel (a map without walls)
        return np.zeros((0, 4), np.int64)
    last = np.nonzero(step == -1)[1] - 1  # the same runs, in the same row-major order
    order = np.lexsort((rows, last, first))  # equal runs together, top to bottom
    rows, first, last = rows[order], first[order], last[order]
    new = np.ones(len(rows), bool)  # a run that does not continue the one above it
    new[1:] = (first[1:] != first[:-1]) | (last[1:] != last[:-1]) | (rows[1:] != rows[:-1] + 1)
    begin = np.flatnonzero(new)
    end = np.append(begin[1:], len(rows)) - 1
    return np.column_stack((rows[begin], first[begin], rows[end], last[end]))


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.asarray(points @ np.array([[c, s], [-s, c]]), float)


def read_map(path: Path, source: str, key: str, files: FilesConfig = DEFAULT_FILES) -> OccupancyMap:
    """Read the map YAML and its picture; problems name the YAML file and the key's line.

    The YAML is read within the bounds of a track.yaml; the picture stays in the YAML's
    folder (unless ``files.paths_outside_folder``) and its size is checked from its header
    against ``files.max_image_pixels`` before it is decoded."""
    text = read_text(path, source, key)
    info = read_info(path, text, files.paths_outside_folder)
    where = _where(text, "image")
    bgr = read_image_bgr(info.image, files.max_image_pixels, str(path), where, str(info.image))
    if min(bgr.shape[:2]) < MIN_MAP_SIDE:
        height, width = bgr.shape[:2]
        allowed = (
            f"expected a map of at least {MIN_MAP_SIDE} x {MIN_MAP_SIDE} cells ({width} x {height})"
        )
        raise ConfigError(Problem(str(path), where, str(info.image), allowed))
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)  # equal channels: the grey values unchanged
    if info.mode == "raw":  # the value is the occupancy in percent; above 100 unknown
        percent = gray.astype(np.float32)
        known = percent <= 100
        free = known & (percent / 100 < info.free_thresh)
        occupied = known & (percent / 100 > info.occupied_thresh)
        return _bounded(OccupancyMap(info, free, occupied), path, where)
    occupancy = gray.astype(np.float32) / 255.0
    if not info.negate:
        occupancy = 1.0 - occupancy
    free, occupied = occupancy < info.free_thresh, occupancy > info.occupied_thresh
    return _bounded(OccupancyMap(info, free, occupied), path, where)


def _bounded(occupancy: OccupancyMap, path: Path, where: str) -> OccupancyMap:
    """``occupancy``, unless its occupied cells make more walls than MAX_MAP_WALLS: each is a
    body in the physics and a box for the lidar (a noisy scan, speckled cell by cell, would
    take minutes and gigabytes to build). A bound counted band by band refuses a speckled
    map before its rectangles are found."""
    at_least = fewest_rects(occupancy.occupied)
    walls = at_least if at_least > MAX_MAP_WALLS else len(occupancy.rects)
    if walls > MAX_MAP_WALLS:
        allowed = (
            f"expected a map whose occupied cells make at most {MAX_MAP_WALLS:,} wall rectangles "
            f"(they make {'at least ' if walls == at_least else ''}{walls:,}: a speckled map? "
            "clean its isolated cells, e.g. with a morphological opening, or raise "
            "occupied_thresh)"
        )
        raise ConfigError(Problem(str(path), where, str(occupancy.info.image.name), allowed))
    return occupancy


def fewest_rects(mask: np.ndarray, band: int = 512) -> int:
    """A lower bound on ``len(pixel_rects(mask))``, in little memory: along rows, each run
    that does not start where a run starts on the row above begins a rectangle of its own;
    the same along columns; ``pixel_rects`` keeps the direction with fewer."""
    return min(_new_run_starts(mask, band), _new_run_starts(mask.T, band))


def _new_run_starts(mask: np.ndarray, band: int) -> int:
    count = 0
    above = np.zeros(mask.shape[1], bool)  # run starts on the row above the band
    for top in range(0, mask.shape[0], band):
        rows = mask[top : top + band]
        starts = rows.copy()
        starts[:, 1:] &= ~rows[:, :-1]  # a True pixel after a False one (or at the edge)
        count += int(np.count_nonzero(starts[0] & ~above))
        count += int(np.count_nonzero(starts[1:] & ~starts[:-1]))
        above = starts[-1]
    return count


def read_info(path: Path, text: str, allow_outside: bool = False) -> MapInfo:
    """The map YAML's keys, checked; every problem names the file and the key's line."""
    data = parse_yaml(text, str(path))  # bounded: nesting, aliases, duplicate keys
    if not isinstance(data, dict):
        raise ConfigError(Problem(str(path), "", data, "expected a mapping of map_server keys"))
    problems: list[Problem] = []

    def bad(key: str, allowed: str) -> None:
        if key not in data:  # (map_server's keys have no default but these)
            allowed = f"the key is missing; {allowed}"
        problems.append(Problem(str(path), _where(text, key), data.get(key), allowed))

    image = data.get("image")
    if not isinstance(image, str) or not image.strip():
        bad("image", "expected the picture's file name, relative to the YAML")
    else:
        try:
            inside_folder(image, path.parent, allow_outside, str(path), _where(text, "image"))
        except ConfigError as error:
            problems += error.problems
        else:
            missing = _not_a_file(path.parent / image)
            if missing:
                named = shown(str(path.parent / image))
                bad("image", f"expected an existing picture; {named} {missing}")
    resolution = data.get("resolution")
    low, high = RESOLUTION_RANGE
    if not _number(resolution) or not low <= resolution <= high:
        bad("resolution", f"expected a number from {low:g} to {high:g} [m/px]")
    origin = data.get("origin")
    if not (isinstance(origin, list) and len(origin) == 3 and all(map(_number, origin))):
        bad("origin", "expected [x, y, yaw] numbers [m, m, rad]")
    elif max(abs(origin[0]), abs(origin[1])) > MAX_COORDINATE:
        bad("origin", f"expected x and y within +-{MAX_COORDINATE:g} m")
    negate = data.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        bad("negate", "expected 0 or 1")
    occupied, free = data.get("occupied_thresh", 0.65), data.get("free_thresh", 0.196)
    for name, value in (("occupied_thresh", occupied), ("free_thresh", free)):
        if not _number(value) or not 0 <= value <= 1:
            bad(name, "expected a number from 0 to 1")
    if _number(occupied) and _number(free) and free > occupied:
        bad("free_thresh", f"expected free_thresh <= occupied_thresh ({occupied})")
    if data.get("mode", "trinary") not in MODES:
        bad("mode", f"expected one of: {', '.join(MODES)}")
    if problems:
        raise ConfigError(problems)
    assert isinstance(image, str) and isinstance(origin, list) and _number(resolution)
    return MapInfo(
        (path.parent / image).resolve(),
        float(resolution),
        (float(origin[0]), float(origin[1]), float(origin[2])),
        bool(negate),
        float(occupied),
        float(free),
        str(data.get("mode", "trinary")),
    )


def _not_a_file(path: Path) -> str:
    """Why ``path`` is no picture to read ("" when it is a regular file)."""
    try:
        if path.is_file():
            return ""
        return "is not a file" if path.exists() else "does not exist"
    except OSError as exc:  # a name too long for the file system, a symlink loop
        return f"cannot be read ({exc.strerror or exc})"


def _number(value: object) -> TypeGuard[float]:
    """A finite int or float (an int too large for a float is not: YAML reads any digits)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _where(text: str, key: str) -> str:
    """'line N (key)' of a top-level key in the YAML text, or the key alone if absent."""
    try:
        root = yaml.compose(text)
    except yaml.YAMLError:
        return key
    if isinstance(root, yaml.MappingNode):
        for name, value in root.value:
            if name.value == key:
                return f"line {value.start_mark.line + 1} ({key})"
    return key
