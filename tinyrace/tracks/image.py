"""Image tracks (tinycarlo 1.1's format): a picture whose pixel colours mean things.

Loaded once per env: the image is binarised at 100 per channel as tinycarlo
does, the trajectory pixels are taken out of the visible picture into a
nearest-point index, and the pixels of each obstacle colour are summarised as
boxes (one per grid cell they occupy) for pymunk's broad phase. Pixels are the
world units: x right, y down.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tinyrace.config import Color, EnvConfig, ImageTrackConfig
from tinyrace.config.image_file import read_image_bgr
from tinyrace.config.paths import inside_folder
from tinyrace.config.schema import FilesConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import (
    ColorLayer,
    PaintedGround,
    Track,
    TrackDraw,
    TrackRules,
    pick_index,
)
from tinyrace.tracks.nearest import NearestPoint

THRESHOLD = 100  # tinycarlo's binarisation threshold per channel
CELL = 32  # [px] side of the obstacle broad-phase cells
_ROWS_PER_CHUNK = 512  # bounds the temporary masks when scanning huge images
CACHED_CELLS = 1024  # obstacle cells whose pixels are kept (cleared when full)


@dataclass(frozen=True, eq=False)
class ImageTrack:
    """One loaded track image and what was read from its colours."""

    image: np.ndarray  # (H, W, 4) uint8 RGBx, binarised, trajectory removed
    spawns: tuple[tuple[float, float, float], ...]  # (x px, y px, heading rad)
    obstacle_colors: tuple[Color, ...]  # per obstacle of reward_design.color_obstacles
    cells: np.ndarray  # (M, 4) float: x0, y0, x1, y1 of cell boxes holding obstacle pixels
    cell_obstacles: np.ndarray  # (M,) int: which obstacle each cell box belongs to
    trajectory: NearestPoint | None  # None unless cross_track_error.use_cte
    trajectory_mask: np.ndarray | None  # (K, 2) int pixel coordinates, for drawing
    path: str  # the image file, for messages

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in px."""
        return self.image.shape[1], self.image.shape[0]

    def packed(self) -> np.ndarray:
        """The image as one uint32 per pixel (RGBx), for fast colour comparisons."""
        return self.image.view(np.uint32)[:, :, 0]


def pack(color: Color) -> np.uint32:
    """The uint32 word of an RGBx pixel of ``color`` (alpha 255)."""
    word: np.uint32 = np.array([*color, 255], np.uint8).view(np.uint32)[0]
    return word


def load_image_track(
    track: ImageTrackConfig, index: int, config: EnvConfig, base_dir: Path, source: str
) -> tuple[ImageTrack | None, list[Problem]]:
    """Load ``tracks[index]``; returns the track or the problems found (file, key path, value)."""
    where = f"tracks[{index}]"
    image, problems = _read_rgbx(track, where, base_dir, source, config.files)
    if image is None:
        return None, problems
    height, width = image.shape[:2]
    for j, (x, y, _) in enumerate(track.spawns):
        if not (0 <= x < width and 0 <= y < height):
            allowed = (
                f"expected a spawn inside the image: 0 <= x < {width} and 0 <= y < {height} [px]"
            )
            problems.append(Problem(source, f"{where}.spawns[{j}]", [x, y, _], allowed))
    for k, camera in enumerate(config.cameras):
        if camera.roi[0] > height or camera.roi[1] > width:
            allowed = f"expected an roi [y, x] no larger than the image [{height}, {width}] [px]"
            problems.append(Problem(source, f"cameras[{k}].roi", list(camera.roi), allowed))
    trajectory, drawn = None, None
    cte = config.reward_design.cross_track_error
    if cte.use_cte:
        drawn = _take_color(image, cte.trajectory_color)
        if len(drawn) == 0:
            allowed = f"expected a colour present in {track.image or 'the plane'} (no pixel has it)"
            problems.append(
                Problem(
                    source,
                    "reward_design.cross_track_error.trajectory_color",
                    cte.trajectory_color,
                    allowed,
                )
            )
        else:
            trajectory = NearestPoint(drawn.astype(np.float64))
    colors = tuple(o.color for o in config.reward_design.color_obstacles)
    cells, owners = _obstacle_cells(image, colors)
    loaded = ImageTrack(
        image, track.spawns, colors, cells, owners, trajectory, drawn, str(track.image)
    )
    return (None if problems else loaded), problems


def _read_rgbx(
    track: ImageTrackConfig, where: str, base_dir: Path, source: str, files: FilesConfig
) -> tuple[np.ndarray | None, list[Problem]]:
    """Read and binarise the image (PNG/JPEG/PGM; RGB, RGBA or grey) as RGBx, within bounds."""
    try:
        if track.image is None:
            return _plane(track.plane_size), []
        # Paths a file names stay in its folder; a dict's or kwargs' are the programmer's own.
        confined = not source.startswith("<") and not files.paths_outside_folder
        path = inside_folder(track.image, base_dir, not confined, source, f"{where}.image")
        bgr = read_image_bgr(path, files.max_image_pixels, source, f"{where}.image", track.image)
    except ConfigError as exc:
        return None, exc.problems
    cv2.threshold(bgr, THRESHOLD, 255, cv2.THRESH_BINARY, dst=bgr)
    rgbx = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGBA)
    del bgr
    return rgbx, []


def _plane(size: tuple[int, int]) -> np.ndarray:
    """The black plane of a track without an image (its size is capped by the config check)."""
    height, width = size
    plane = np.zeros((height, width, 4), np.uint8)
    plane[:, :, 3] = 255
    return plane


def _take_color(image: np.ndarray, color: Color) -> np.ndarray:
    """Coordinates (x, y) of every pixel of ``color``, painted black in the image."""
    packed = image.view(np.uint32)[:, :, 0]
    word, black = pack(color), pack(Color.rgb(0, 0, 0))
    found = []
    for top in range(0, packed.shape[0], _ROWS_PER_CHUNK):
        rows = packed[top : top + _ROWS_PER_CHUNK]
        ys, xs = np.nonzero(rows == word)
        rows[ys, xs] = black
        found.append(np.stack([xs, ys + top], axis=1))
    return np.concatenate(found) if found else np.zeros((0, 2), np.int64)


def _obstacle_cells(image: np.ndarray, colors: tuple[Color, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Tight boxes around the obstacle pixels of each CELL x CELL grid cell, per colour."""
    packed = image.view(np.uint32)[:, :, 0]
    boxes, owners = [], []
    for owner, color in enumerate(colors):
        word = pack(color)
        for top in range(
            0, packed.shape[0], _ROWS_PER_CHUNK
        ):  # _ROWS_PER_CHUNK is a multiple of CELL
            hits = packed[top : top + _ROWS_PER_CHUNK] == word
            found = _cell_boxes(hits)
            if len(found):
                found[:, [1, 3]] += top
                boxes.append(found)
                owners.append(np.full(len(found), owner))
    if not boxes:
        return np.zeros((0, 4)), np.zeros(0, np.int64)
    # pixel (x, y) is centred on integer coordinates: it spans x - 0.5 .. x + 0.5
    return np.concatenate(boxes).astype(np.float64) - 0.5, np.concatenate(owners)


def _cell_boxes(hits: np.ndarray) -> np.ndarray:
    """(M, 4) int boxes x0, y0, x1, y1 (exclusive ends) of the hits within each occupied cell."""
    h, w = hits.shape
    ph, pw = -h % CELL, -w % CELL
    grid: np.ndarray = np.pad(hits, ((0, ph), (0, pw))).reshape(
        (h + ph) // CELL, CELL, (w + pw) // CELL, CELL
    )
    rows_hit: Any = grid.any(axis=3)  # (gy, CELL, gx): which rows of each cell hold a hit
    cols_hit: Any = grid.any(axis=1)  # (gy, gx, CELL)
    gy, gx = np.nonzero(rows_hit.any(axis=1))
    if len(gy) == 0:
        return np.zeros((0, 4), np.int64)
    r = rows_hit[gy, :, gx]  # (M, CELL)
    c = cols_hit[gy, gx, :]
    y0 = r.argmax(axis=1)
    y1 = CELL - r[:, ::-1].argmax(axis=1)
    x0 = c.argmax(axis=1)
    x1 = CELL - c[:, ::-1].argmax(axis=1)
    return np.stack([gx * CELL + x0, gy * CELL + y0, gx * CELL + x1, gy * CELL + y1], axis=1)


# tinycarlo's rules: obstacle colours under the footprint, the distance to a trajectory,
# the picture's bounds at the rear axle; a reset looks at the spawn without moving the car
IMAGE_RULES = TrackRules(
    ("obstacle_colours", "trajectory_error", "playfield"),
    bounds_point="rear_axle",
    info_labels=("track", "spawn"),
)


class ObstaclePixels:
    """The obstacle pixels of an image track, per cell box, each cell's found on first use.

    The narrow phase of the obstacle test: pymunk reports which cell boxes the footprint
    overlaps, and only their pixels are tested against it. A pixel inside the footprint
    lies in a box that the footprint overlaps, so this is as exact as a test of every pixel.
    A box wholly inside the footprint needs no pixel test: it holds at least one pixel.
    Nor does a box one of whose outermost pixels (its probes) lies inside.
    """

    def __init__(self, track: ImageTrack):
        self.track = track
        self.cells = track.cells  # (M, 4) boxes [px], in the order the world's sensors have them
        self._boxes: list[list[float]] = track.cells.tolist()  # x0, y0, x1, y1 per cell
        self._owners: list[int] = track.cell_obstacles.tolist()  # obstacle index per cell
        self._pixels: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # by cell: x, y
        self._probes: dict[int, list[tuple[float, float]]] = {}  # by cell: a few pixels' x, y

    def of_cell(self, cell: int) -> tuple[np.ndarray, np.ndarray]:
        """Centres x [px] (float) and rows y (int) of the obstacle pixels in cell box ``cell``."""
        found = self._pixels.get(cell)
        if found is None:
            track = self.track
            x0, y0, x1, y1 = (int(v + 0.5) for v in self._boxes[cell])  # exclusive ends
            word = pack(track.obstacle_colors[self._owners[cell]])
            ys, xs = np.nonzero(track.packed()[y0:y1, x0:x1] == word)
            if len(self._pixels) >= CACHED_CELLS:
                self._pixels.clear()
                self._probes.clear()
            found = (xs + x0).astype(np.float64), ys + y0
            self._pixels[cell] = found
        return found

    def probes(self, cell: int) -> list[tuple[float, float]]:
        """Centres (x, y) [px] of the leftmost, rightmost, top and bottom pixels of a cell."""
        probes = self._probes.get(cell)
        if probes is None:
            xs, ys = self.of_cell(cell)  # clears the probes too when its cache is full
            ends = sorted({int(xs.argmin()), int(xs.argmax()), int(ys.argmin()), int(ys.argmax())})
            probes = self._probes[cell] = [(float(xs[i]), float(ys[i])) for i in ends]
        return probes

    def touched(self, corners: np.ndarray, cells: Iterable[int]) -> list[int]:
        """The obstacles (indices, ascending) with a pixel of ``cells`` whose centre lies
        inside the convex polygon ``corners`` or on its edge."""
        listed = corners.tolist()
        edges = _inner_edges(listed)
        hit: set[int] = set()
        unsure: dict[int, list[int]] = {}  # by obstacle: cells whose pixels need a test
        for cell in cells:
            owner = self._owners[cell]
            if owner in hit:
                continue
            if edges and _box_inside(self._boxes[cell], edges):
                hit.add(owner)
                unsure.pop(owner, None)
            else:
                unsure.setdefault(owner, []).append(cell)
        spans = _span_edges(listed) if unsure else []
        for owner, owned in unsure.items():
            probes = [xy for cell in owned for xy in self.probes(cell)]
            if any(_inside_span(spans, x, y) for x, y in probes) or _any_inside(
                corners, [self.of_cell(cell) for cell in owned]
            ):
                hit.add(owner)
        return sorted(hit)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_pixels": {}, "_probes": {}}  # caches: refilled when needed


# An edge: start x, y and direction dx, dy [px], then the box corner that is least inside it
Edge = tuple[float, float, float, float, bool, bool]  # ..., take x1, take y1


def _inner_edges(corners: list[list[float]]) -> list[Edge]:
    """The edges of a convex polygon, in the order that puts its inside on the positive side
    of each edge's cross product (see _box_inside); none for a polygon without area."""
    pairs = list(zip(corners, corners[1:] + corners[:1], strict=True))
    area = sum(ax * by - bx * ay for (ax, ay), (bx, by) in pairs)  # twice the signed area
    if area == 0:
        return []
    if area < 0:
        pairs = [(b, a) for a, b in reversed(pairs)]
    # dx * (y - ay) - dy * (x - ax) is smallest at y0 when dx >= 0 and at x1 when dy >= 0
    return [(ax, ay, bx - ax, by - ay, by - ay >= 0, bx - ax < 0) for (ax, ay), (bx, by) in pairs]


def _box_inside(box: list[float], edges: list[Edge]) -> bool:
    """Whether the corners of ``box`` (x0, y0, x1, y1) all lie inside the polygon of ``edges``
    or on its edge. Its pixel centres then lie at least half a pixel inside.

    Per edge only the corner least inside is tested: the rounded cross product grows
    monotonically with each coordinate, so it is the smallest of the four as computed.
    """
    x0, y0, x1, y1 = box
    for ax, ay, dx, dy, take_x1, take_y1 in edges:
        x = x1 if take_x1 else x0
        y = y1 if take_y1 else y0
        if dx * (y - ay) - dy * (x - ax) < 0:
            return False
    return True


def _any_inside(corners: np.ndarray, pixels: list[tuple[np.ndarray, np.ndarray]]) -> bool:
    """Whether a pixel of ``pixels`` (per cell: centres x (float) and rows y (int)) has its
    centre inside the convex polygon ``corners`` or on its edge."""
    xs = np.concatenate([x for x, _ in pixels]) if len(pixels) > 1 else pixels[0][0]
    ys = np.concatenate([y for _, y in pixels]) if len(pixels) > 1 else pixels[0][1]
    top = int(ys.min())
    left, right = _row_spans(corners, np.arange(top, int(ys.max()) + 1, dtype=np.float64))
    rows = ys - top
    return bool(((xs >= np.ceil(left)[rows]) & (xs <= np.floor(right)[rows])).any())


def _row_spans(corners: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leftmost and rightmost x of the convex polygon ``corners`` on each horizontal line ``rows``.

    Rows that miss the polygon get an empty span (left > right). A level edge needs no
    case of its own: its ends are the ends of the edges next to it.
    """
    sx, sy = corners[:, 0], corners[:, 1]
    ends = np.concatenate([corners[1:], corners[:1]])  # each corner's successor
    rise = ends[:, 1] - sy
    slope = np.divide(ends[:, 0] - sx, rise, out=np.zeros(len(rise)), where=rise != 0)
    xs = sx + (rows[:, None] - sy) * slope  # (rows, edges)
    crosses = (rows[:, None] >= np.minimum(sy, ends[:, 1])) & (
        rows[:, None] <= np.maximum(sy, ends[:, 1])
    )
    left = np.where(crosses, xs, np.inf).min(axis=1)
    right = np.where(crosses, xs, -np.inf).max(axis=1)
    return left, right


SpanEdge = tuple[float, float, float, float, float]  # lowest y, highest y, start x, y, slope


def _span_edges(corners: list[list[float]]) -> list[SpanEdge]:
    """The edges of the polygon ``corners`` as _row_spans reads them, for _inside_span."""
    edges = []
    for (sx, sy), (ex, ey) in zip(corners, corners[1:] + corners[:1], strict=True):
        rise = ey - sy
        edges.append((min(sy, ey), max(sy, ey), sx, sy, (ex - sx) / rise if rise != 0 else 0.0))
    return edges


def _inside_span(edges: list[SpanEdge], x: float, y: float) -> bool:
    """Whether the pixel centre (x, y) (whole numbers) lies in its row's span of the polygon,
    computed exactly as _row_spans does (the same operations in the same order)."""
    left, right = math.inf, -math.inf
    for low, high, sx, sy, slope in edges:
        if low <= y <= high:
            at = sx + (y - sy) * slope
            left, right = min(left, at), max(right, at)
    return left <= x <= right  # for a whole x: ceil(left) <= x <= floor(right)


class ImageSource:
    """``track.type: image``: tinycarlo track images, each loaded once per env."""

    kind = "image"
    painted: PaintedGround | None = None  # the ground is each track's picture

    def __init__(self, config: EnvConfig, base_dir: Path, source: str):
        loaded, problems = [], []
        for index, track_config in enumerate(config.tracks):
            assert isinstance(track_config, ImageTrackConfig)  # one kind per env (checked)
            track, found = load_image_track(track_config, index, config, base_dir, source)
            problems += found
            if track is not None:
                loaded.append(track)
        if not problems:
            problems = _unseen_obstacles(config, loaded, source)
        if problems:
            raise ConfigError(problems)
        cte = config.reward_design.cross_track_error
        scales = [getattr(t, "pixels_per_meter", None) for t in config.tracks]
        self.tracks = tuple(
            as_track(t, cte.trajectory_color, ppm) for t, ppm in zip(loaded, scales, strict=True)
        )

    def draw(self, rng: np.random.Generator, options: Mapping[str, object]) -> TrackDraw:
        """A track then a spawn, each drawn from ``rng`` unless ``options`` picks it."""
        track_index = pick_index(options, "track", len(self.tracks), rng)
        spawn_index = pick_index(options, "spawn", len(self.tracks[track_index].spawns), rng)
        return TrackDraw(self.tracks[track_index], track_index, spawn_index)


def _unseen_obstacles(config: EnvConfig, tracks: list[ImageTrack], source: str) -> list[Problem]:
    """A Problem for each obstacle colour that no pixel of any track has: the car could never
    hit it (often a colour written [r, g, b] where tinycarlo's order is [b, g, r])."""
    seen = set(np.concatenate([track.cell_obstacles for track in tracks]).tolist())
    images = ", ".join(sorted({track.path for track in tracks}))
    problems = []
    for k, obstacle in enumerate(config.reward_design.color_obstacles):
        if k not in seen:
            b, g, r = obstacle.color.bgr
            swapped = pack(Color.rgb(b, g, r))  # the list read the other way round
            if any((track.packed() == swapped).any() for track in tracks):
                hint = f"; the image has [{r}, {g}, {b}]: a list is [b, g, r], tinycarlo's order"
            else:
                hint = '; a list is [b, g, r], tinycarlo\'s order, or give "#rrggbb"'
            allowed = (
                f"expected a colour present in {images} (no pixel has it, so the car could "
                f"never hit it{hint})"
            )
            where = f"reward_design.color_obstacles[{k}].color"
            problems.append(Problem(source, where, obstacle.color, allowed))
    return problems


def as_track(
    image_track: ImageTrack, trajectory_color: Color, pixels_per_meter: float | None = None
) -> Track:
    """The generic view of a loaded image track: pixels are the unit, y points down."""
    width, height = image_track.size
    layers = [
        ColorLayer(
            f"obstacle {i}",
            "obstacle",
            color,
            cells=image_track.cells[image_track.cell_obstacles == i],
        )
        for i, color in enumerate(image_track.obstacle_colors)
    ]
    if image_track.trajectory_mask is not None:
        points = image_track.trajectory_mask
        layers.append(ColorLayer("trajectory", "trajectory", trajectory_color, points=points))
    return Track(
        kind="image",
        unit="px",
        metres_per_unit=None if pixels_per_meter is None else 1.0 / pixels_per_meter,
        y_down=True,
        bounds=(-0.5, -0.5, width - 0.5, height - 0.5),
        spawns=image_track.spawns,
        layers=tuple(layers),
        picture=image_track.image,
        rules=IMAGE_RULES,
        obstacle_test=ObstaclePixels(image_track),
        trajectory=image_track.trajectory,
        path=image_track.path,
    )
