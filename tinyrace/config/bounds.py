"""Fixed bounds on what tinyrace reads and builds: each a constant, listed in the reference.

They are not knobs (``files.max_image_pixels`` is the one bound a config may change): they keep
a careless or hostile input from taking unbounded time or memory, and every refusal names the
bound. The sizes a config asks for are checked against them before anything is allocated.
"""

from __future__ import annotations

from dataclasses import dataclass

from tinyrace.cache.disk import LOCK_WAIT as MAX_LOCK_WAIT  # [s] then a private build


@dataclass(frozen=True)
class Bound:
    """One fixed bound: its name in the code, its value and unit, and what it bounds."""

    name: str
    value: float
    unit: str
    what: str


MAX_DATA_BYTES = 64 << 20  # [bytes] a track data file (a real circuit's CSV is ~50 kB)
MAX_ROWS = 200_000  # rows of numbers in a track data file (a real circuit has ~1,000 points)
MAX_COORDINATE = 1e7  # [m] |x|, |y| and widths of metric track files after scale
MIN_ROAD_WIDTH = 0.1  # [m] right + left width at a point of a centreline: narrower than a car
# The road's width to the inside of a curve over the curve's radius (polyline.
# inner_width_over_radius): above 1 the inner edge passes the centre and the road folds.
# The racetrack-database's 24 open circuits reach 1.01 (Norisring's hairpin) at 0.1 m spacing.
MAX_INNER_WIDTH_OVER_RADIUS = 1.2
MAX_TRACK_POINTS = 100_000  # centreline points after resampling (track length / spacing)
MAX_CONES = 5_000  # cones in one cone map (a Formula Student track has a few hundred)
MAX_CONE_ROAD_POINTS = 5_000  # an edge of a cone map / spacing (the road is matched edge to edge)
# [m] the farthest a cone may stand from a cone map's road (its middle line): a stray cone
# far away would stretch the playfield, and the ground's pixels with it, to reach it
MAX_CONE_OFF_ROAD = 100.0
MIN_MAP_SIDE = 2  # [cells] a ROS map's width and height
MAX_MAP_WALLS = 100_000  # wall rectangles of one ROS map (f1tenth_gym's example: 2,083)
RESOLUTION_RANGE = (1e-4, 1e3)  # [m/px] a ROS map's resolution (F1TENTH maps: 0.05)
MAX_CROSSING_PAIRS = 50_000_000  # segment pairs sharing grid cells in the self-crossing check
MAX_TEXTURE_SIDE = 8192  # [px] the procedural ground texture: 8192^2 RGBx is 256 MiB
MAX_INTRINSIC = 1e15  # [px] |fx|, |fy|, |cx|, |cy| of a perspective camera (1e12: a long telephoto)
MAX_CAMERA_PIXELS = 4096 * 4096  # [px] all cameras' images of one env (every car's) together
PERSPECTIVE_PIXEL_WEIGHT = 4  # a perspective camera's pixel counts 4 (it keeps a ray per pixel)
MAX_LOOKAHEAD_GRID = 1_000_000  # grid points of a lookahead sensor's line (8 per spacing)
MAX_ENVS = 256  # envs of one vector env (each holds its own track, textures and car)
MAX_WORKERS = 64  # worker processes of one vector env
MAX_RUN_FILE_BYTES = 128 << 20  # [bytes] results.json, episodes.csv or a trace, for report
MAX_CSV_FIELD = 4096  # [characters] one field of episodes.csv or a trace, for report
MAX_EPISODES = 1_000_000  # episodes of one run (--episodes and the episodes key)
MAX_ID_LENGTH = 64  # [characters] a car's id (race.cars[i].id): it names the car in files
ID_CHARACTERS = (
    "printable characters other than spaces (letters of any script, digits, punctuation)"
)
MAX_TRAIN_ENVS = 64  # envs of `tinyrace train --envs` (a slice per core with --subprocesses)
MAX_SEED = 2**63 - 1  # the largest first seed of --seed (numpy's seeds are 64-bit)

BOUNDS = (
    Bound("MAX_DATA_BYTES", MAX_DATA_BYTES, "bytes", "a track data file (CSV, map YAML)"),
    Bound("MAX_ROWS", MAX_ROWS, "rows", "rows of numbers in a centreline or waypoint CSV"),
    Bound("MAX_COORDINATE", MAX_COORDINATE, "m", "coordinates and widths after scale"),
    Bound("MAX_TRACK_POINTS", MAX_TRACK_POINTS, "points", "a centreline after resampling"),
    Bound("MAX_CONES", MAX_CONES, "cones", "cones in one cone map"),
    Bound(
        "MAX_CONE_ROAD_POINTS",
        MAX_CONE_ROAD_POINTS,
        "points",
        "a cone map's edge length / spacing (2.5 km at the default 0.5 m)",
    ),
    Bound("MAX_CONE_OFF_ROAD", MAX_CONE_OFF_ROAD, "m", "a cone from a cone map's road"),
    Bound("MIN_MAP_SIDE", MIN_MAP_SIDE, "cells", "a ROS map's width and height (at least)"),
    Bound("RESOLUTION_RANGE", RESOLUTION_RANGE[1], "m/px", "a ROS map's resolution, from 1e-4"),
    Bound(
        "MAX_CROSSING_PAIRS",
        MAX_CROSSING_PAIRS,
        "pairs",
        "segments crowding one area in the self-crossing check (n log n on even points)",
    ),
    Bound("MAX_LOOKAHEAD_GRID", MAX_LOOKAHEAD_GRID, "points", "a lookahead sensor's line grid"),
    Bound(
        "MAX_CAMERA_PIXELS",
        MAX_CAMERA_PIXELS,
        "px",
        "cameras and perspective cameras of one env together (every car's), a perspective "
        "pixel counted "
        f"{PERSPECTIVE_PIXEL_WEIGHT} times (PERSPECTIVE_PIXEL_WEIGHT: it keeps a ray each)",
    ),
    Bound("MAX_ENVS", MAX_ENVS, "envs", "num_envs of make_vec / make_batch"),
    Bound("MAX_WORKERS", MAX_WORKERS, "processes", "workers of a vector env"),
    Bound("MAX_RUN_FILE_BYTES", MAX_RUN_FILE_BYTES, "bytes", "a run file read by report"),
    Bound("MAX_CSV_FIELD", MAX_CSV_FIELD, "characters", "a field of a run's CSV files"),
    Bound("MAX_EPISODES", MAX_EPISODES, "episodes", "episodes of one run"),
    Bound(
        "MAX_ID_LENGTH",
        MAX_ID_LENGTH,
        "characters",
        f"a car id (race.cars[i].id) of {ID_CHARACTERS} (ID_CHARACTERS)",
    ),
    Bound(
        "MAX_TRAIN_ENVS",
        MAX_TRAIN_ENVS,
        "envs",
        "tinyrace train --envs (stepped in this process; with --subprocesses, a slice per core: "
        "this process steps one, a worker process each of the others)",
    ),
    Bound(
        "MAX_LOCK_WAIT",
        MAX_LOCK_WAIT,
        "s",
        "a wait for a cache entry another process builds; then it is built privately",
    ),
    Bound("MAX_INTRINSIC", MAX_INTRINSIC, "px", "a perspective camera's fx, fy, cx, cy"),
)


def id_problem(text: object) -> str | None:
    """Why ``text`` is no car id (None when it is one): 1 to MAX_ID_LENGTH characters of
    ID_CHARACTERS."""
    if not isinstance(text, str) or not text:
        return "expected a non-empty string"
    if len(text) > MAX_ID_LENGTH:
        return f"expected at most {MAX_ID_LENGTH} characters (it has {len(text)})"
    if not text.isprintable() or " " in text:
        return f"expected {ID_CHARACTERS}"
    return None
