"""Generate the three example track folders shipped with tinyrace.

Usage::

    python example_tracks/make_example_tracks.py [OUT_DIR]

OUT_DIR defaults to the folder of this script (``example_tracks/``). Each track folder gets a
``track.yaml`` in tinycarlo 1.1's format (lists under ``tracks:`` and
``cameras:``) and one PNG image:

- ``segmented/``: a two-lane road whose markings are segmented by class, one
  pure colour per class.
- ``formula_student/``: a corridor marked by blue cones on the left and yellow
  cones on the right.
- ``carolo_cup/``: white markings on black, with obstacle boxes in the left lane.

It then runs ``make_metric_tracks.py`` for the tracks in metres (a centreline CSV,
a cone map, a ROS map with a raceline).

Conventions (tinycarlo's): positions are image pixels, x right and y down;
heading 0 points along +x and a growing heading turns clockwise on screen.
Colours are BGR with every channel 0 or 255. Drawing uses ``cv2.LINE_8`` (no
antialiasing), so every pixel is a pure colour. Nothing here is random: the
output is the same on every run.
"""

from __future__ import annotations

import math
import runpy
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

Color = tuple[int, int, int]  # BGR, each channel 0 or 255

BLACK: Color = (0, 0, 0)
WHITE: Color = (255, 255, 255)
BLUE: Color = (255, 0, 0)
GREEN: Color = (0, 255, 0)
RED: Color = (0, 0, 255)
YELLOW: Color = (0, 255, 255)
MAGENTA: Color = (255, 0, 255)

SMOOTHING_PX = 150.0  # length of the curvature ramp between straights and arcs [px]
SAMPLE_STEP_PX = 2.0  # spacing of centre-line samples [px]
CANVAS_MARGIN_PX = 60  # black border around the outermost marking [px]
ROAD_LANE_PX = 260.0  # lane width, line centre to line centre [px]
EDGE_LINE_PX = 10  # solid edge line thickness [px]
CENTRE_LINE_PX = 8  # dashed centre line thickness [px]
TRAJECTORY_PX = 2  # cv2 thickness of the trajectory line; draws about 3 px wide


# --------------------------------------------------------------------------
# Centre-line geometry
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Straight:
    """A straight piece of a loop."""

    length: float  # [px]


@dataclass(frozen=True)
class Arc:
    """A circular piece of a loop; a positive angle turns right (clockwise on screen)."""

    radius: float  # [px]
    angle_deg: float  # [deg], + right, - left

    @property
    def length(self) -> float:
        """Arc length [px]."""
        return self.radius * math.radians(abs(self.angle_deg))


Piece = Straight | Arc


@dataclass(frozen=True)
class Loop:
    """A closed, evenly sampled centre line.

    ``points[i]`` is a position [px] and ``headings[i]`` the driving direction
    there [rad]; the last sample connects back to the first.
    """

    points: np.ndarray  # (N, 2) float [px]
    headings: np.ndarray  # (N,) [rad]
    piece_starts: np.ndarray  # sample index where each piece begins

    def offset(self, distance: float) -> np.ndarray:
        """The curve ``distance`` px to the right of the driving direction (negative: left)."""
        right = np.stack([-np.sin(self.headings), np.cos(self.headings)], axis=1)
        return self.points + distance * right

    def index_in(self, piece: int, fraction: float) -> int:
        """Sample index ``fraction`` of the way through piece ``piece``."""
        n = len(self.points)
        start = int(self.piece_starts[piece])
        end = int(self.piece_starts[(piece + 1) % len(self.piece_starts)])
        span = (end - start) % n
        return (start + round(fraction * span)) % n

    def shifted(self, dx: float, dy: float) -> Loop:
        """The same loop translated by (dx, dy) px."""
        return Loop(self.points + np.array([dx, dy]), self.headings, self.piece_starts)


def closed_with_arc_length(curve: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``curve`` with its first point repeated at the end, and the arc length [px] at each point."""
    closed = np.concatenate([curve, curve[:1]])
    steps = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    return closed, np.concatenate([[0.0], np.cumsum(steps)])


def _piece_turn(piece: Piece) -> float:
    """Signed heading change over a piece [rad]."""
    return math.radians(piece.angle_deg) if isinstance(piece, Arc) else 0.0


def _trace(pieces: list[Piece], heading0: float) -> tuple[Loop, np.ndarray]:
    """Integrate the smoothed curvature of ``pieces``; returns the loop and its closing gap [px].

    Sampling starts in the middle of the first piece (a straight), so the
    smoothing never tilts it. The curvature is a moving average over
    SMOOTHING_PX, which turns each corner into clothoid-like ramps (no
    curvature jumps) while keeping every piece's total turn.
    """
    lengths = np.array([p.length for p in pieces])
    turns = np.array([_piece_turn(p) for p in pieces])
    total = float(lengths.sum())
    n = round(total / SAMPLE_STEP_PX)
    ds = total / n
    ends = np.concatenate([[0.0], np.cumsum(lengths)])
    turned = np.concatenate([[0.0], np.cumsum(turns)])
    s_start = lengths[0] / 2
    s_nodes = s_start + np.arange(n + 1) * ds
    # Exact turn within each sample interval, so the loop turns by exactly 360 deg.
    turn_at = np.interp(s_nodes % total, ends, turned) + turned[-1] * (s_nodes // total)
    sample_turn = np.diff(turn_at)
    half = round(SMOOTHING_PX / SAMPLE_STEP_PX / 2)
    padded = np.concatenate([sample_turn[-half:], sample_turn, sample_turn[:half]])
    sample_turn = np.convolve(padded, np.ones(2 * half + 1) / (2 * half + 1), mode="valid")
    heading_nodes = heading0 + np.concatenate([[0.0], np.cumsum(sample_turn)])
    heading_mid = (heading_nodes[:-1] + heading_nodes[1:]) / 2
    steps = ds * np.stack([np.cos(heading_mid), np.sin(heading_mid)], axis=1)
    points = np.concatenate([[[0.0, 0.0]], np.cumsum(steps, axis=0)])
    starts = np.round(((ends[:-1] - s_start) % total) / ds).astype(int) % n
    loop = Loop(points[:-1], heading_nodes[:-1], starts)
    return loop, points[-1] - points[0]


def closed_loop(pieces: list[Piece], free: tuple[int, int], heading0: float = 0.0) -> Loop:
    """A smooth closed centre line from straights and arcs.

    The lengths of the two straights named by ``free`` (indices into
    ``pieces``, not parallel) are adjusted so the loop closes; the pieces'
    turns must add up to one full turn.
    """
    turn = sum(_piece_turn(p) for p in pieces)
    assert abs(abs(turn) - 2 * math.pi) < 1e-9, "a loop turns by exactly 360 deg"
    pieces = list(pieces)
    directions = np.cumsum([heading0] + [_piece_turn(p) for p in pieces])[:-1]
    # Closing gap is linear in the free lengths: each adds length * its direction.
    jacobian = np.array([[math.cos(directions[i]), math.sin(directions[i])] for i in free]).T
    for _ in range(20):
        loop, gap = _trace(pieces, heading0)
        if np.hypot(*gap) < 0.05:
            break
        delta = np.linalg.solve(jacobian, -gap)
        for i, d in zip(free, delta, strict=True):
            pieces[i] = Straight(pieces[i].length + float(d))
            assert pieces[i].length > SMOOTHING_PX, "free straight too short to close the loop"
    assert np.hypot(*gap) < 0.5, "loop did not close"
    return loop


def fit_canvas(loop: Loop, reach_px: float) -> tuple[Loop, tuple[int, int]]:
    """Move ``loop`` onto a canvas that holds everything within ``reach_px`` of it.

    Returns the moved loop and the canvas (height, width) [px].
    """
    extent = np.concatenate([loop.offset(reach_px), loop.offset(-reach_px)])
    low = np.floor(extent.min(axis=0)) - CANVAS_MARGIN_PX
    high = np.ceil(extent.max(axis=0)) + CANVAS_MARGIN_PX
    width, height = (high - low).astype(int)
    return loop.shifted(-low[0], -low[1]), (int(height), int(width))


# --------------------------------------------------------------------------
# Drawing steps (all cv2.LINE_8: no antialiasing, pure colours only)
# --------------------------------------------------------------------------


def _pixels(points: np.ndarray) -> np.ndarray:
    """Float positions [px] as int32 pixel coordinates for OpenCV."""
    return np.round(points).astype(np.int32)


def draw_solid_line(image: np.ndarray, curve: np.ndarray, color: Color, thickness: int) -> None:
    """A closed solid line along ``curve``."""
    cv2.polylines(image, [_pixels(curve)], True, color, thickness, cv2.LINE_8)


def draw_dashed_line(
    image: np.ndarray, curve: np.ndarray, color: Color, thickness: int, dash_px: float
) -> None:
    """A dashed line along the closed ``curve``: dashes and gaps both about ``dash_px`` long.

    The period is stretched slightly so a whole number of dashes fits the loop.
    """
    closed, s = closed_with_arc_length(curve)
    count = max(1, round(s[-1] / (2 * dash_px)))
    period = s[-1] / count
    for k in range(count):
        inside = (s >= k * period) & (s <= k * period + period / 2)
        cv2.polylines(image, [_pixels(closed[inside])], False, color, thickness, cv2.LINE_8)


def draw_box(
    image: np.ndarray, centre: np.ndarray, heading: float, size: tuple[float, float], color: Color
) -> None:
    """A filled rectangle ``size`` = (length along heading, width) [px] centred on ``centre``."""
    forward = np.array([math.cos(heading), math.sin(heading)]) * size[0] / 2
    right = np.array([-math.sin(heading), math.cos(heading)]) * size[1] / 2
    corners = np.array([-forward - right, forward - right, forward + right, -forward + right])
    cv2.fillConvexPoly(image, _pixels(centre + corners), color, cv2.LINE_8)


def draw_cones(
    image: np.ndarray, curve: np.ndarray, color: Color, spacing_px: float, radius: int
) -> None:
    """Filled circles evenly spaced (about ``spacing_px``) along the closed ``curve``."""
    closed, s = closed_with_arc_length(curve)
    count = round(s[-1] / spacing_px)
    for target in np.arange(count) * s[-1] / count:
        x = np.interp(target, s, closed[:, 0])
        y = np.interp(target, s, closed[:, 1])
        cv2.circle(image, (round(x), round(y)), radius, color, -1, cv2.LINE_8)


def draw_crosswalk(
    image: np.ndarray, loop: Loop, index: int, road_half_px: float, color: Color
) -> None:
    """Zebra stripes across the whole road at sample ``index``.

    Stripes run along the road; the road under them is cleared first so no
    other marking (the dashed centre line) shows between the stripes.
    """
    centre, heading = loop.points[index], float(loop.headings[index])
    stripe_px, depth_px = 30.0, 140.0
    clear_half = road_half_px - 12  # keep the edge lines intact
    draw_box(image, centre, heading, (depth_px + 2 * stripe_px, 2 * clear_half), BLACK)
    right = np.array([-math.sin(heading), math.cos(heading)])
    count = int(2 * clear_half // (2 * stripe_px))
    for k in range(count):
        across = -clear_half + stripe_px * (2 * k + 1)
        draw_box(image, centre + across * right, heading, (depth_px, stripe_px), color)


def draw_two_lane_road(
    image: np.ndarray, loop: Loop, edge: Color, centre: Color, dash_px: float
) -> None:
    """Solid edge lines ROAD_LANE_PX either side of ``loop`` and a dashed line on it."""
    draw_solid_line(image, loop.offset(ROAD_LANE_PX), edge, EDGE_LINE_PX)
    draw_solid_line(image, loop.offset(-ROAD_LANE_PX), edge, EDGE_LINE_PX)
    draw_dashed_line(image, loop.points, centre, CENTRE_LINE_PX, dash_px)


def draw_stop_line(
    image: np.ndarray,
    loop: Loop,
    index: int,
    lane_px: float,
    side: int,
    color: Color,
) -> None:
    """A bar across one lane at sample ``index``; ``side`` +1 = right lane, -1 = left lane."""
    heading = float(loop.headings[index])
    centre = loop.offset(side * lane_px / 2)[index]
    draw_box(image, centre, heading, (20.0, lane_px - 24), color)


def spawns_on(loop: Loop, curve: np.ndarray, indices: list[int]) -> list[list[float]]:
    """Spawns [x px, y px, heading rad] on ``curve`` at the given sample indices."""
    return [
        [
            round(float(curve[i, 0]), 1),
            round(float(curve[i, 1]), 1),
            round(math.remainder(float(loop.headings[i]), math.tau), 4) + 0.0,  # no -0.0
        ]
        for i in indices
    ]


# --------------------------------------------------------------------------
# track.yaml
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Obstacle:
    """A colour obstacle of track.yaml."""

    color: Color
    reward: int | str  # an int, or "done"
    meaning: str


def _bgr(color: Color) -> str:
    return "[" + ",".join(str(c) for c in color) + "]"


def _line(text: str, comment: str = "") -> str:
    """A YAML line with its comment aligned in one column."""
    return f"{text.ljust(27)}  # {comment}" if comment else text


def track_yaml(
    title: str,
    legend: list[str],
    obstacles: list[Obstacle],
    trajectory: Color,
    image_name: str,
    spawns: list[list[float]],
) -> str:
    """track.yaml text in tinycarlo 1.1's format, with units in comments."""
    lines = [
        f"# {title}",
        "# Made by example_tracks/make_example_tracks.py: edit the script, not this file.",
    ]
    lines += [f"# {line}" for line in legend]
    lines += [
        "sim:",
        _line("  fps: 30", "steps per simulated second"),
        _line("  render_realtime: True", "human view only"),
        _line("  step_limit: 1000", "steps per episode"),
        _line("  overview_downscale: 2", "overview window = image size / 2"),
        "reward_design:",
        "  color_obstacles:",
    ]
    for obstacle in obstacles:
        lines.append(_line(f"    - color: {_bgr(obstacle.color)}", f"BGR, {obstacle.meaning}"))
        lines.append(_line(f"      reward: {obstacle.reward}"))
    lines += [
        "  cross_track_error:",
        "    use_cte: True",
        _line(f"    trajectory_color: {_bgr(trajectory)}", "BGR"),
        "car:",
        _line("  wheelbase: 150", "px, rear axle to front axle"),
        _line("  track_width: 100", "px"),
        _line("  velocity: 400", "px/s"),
        _line("  max_steering_change: 180", "deg/s"),
        "cameras:",
        "  - id: front_camera",
        _line("    resolution: [120,160]", "[y,x] output pixels"),
        _line("    roi: [360,480]", "[y,x] track pixels seen"),
        _line("    position: [0,0]", "[y,x] px from the middle of the front axle"),
        "tracks:",
        f"  - image: {image_name}",
        _line("    spawns:", "[x px, y px, heading rad]; heading 0 = +x, grows clockwise"),
    ]
    lines += [f"      - [{x}, {y}, {heading}]" for x, y, heading in spawns]
    return "\n".join(lines) + "\n"


def write_track(folder: Path, image_name: str, image: np.ndarray, yaml_text: str) -> None:
    """Write one track folder: the PNG (max compression) and track.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    ok = cv2.imwrite(str(folder / image_name), image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    assert ok, f"could not write {folder / image_name}"
    (folder / "track.yaml").write_text(yaml_text)


# --------------------------------------------------------------------------
# The three tracks
# --------------------------------------------------------------------------


def segmented_track(out_dir: Path) -> None:
    """Two-lane road, driven anticlockwise on screen, markings segmented by class."""
    pieces: list[Piece] = [
        Straight(800),  # south side, eastbound; crosswalk here (free: closes the loop)
        Arc(350, -90),
        Straight(300),
        Arc(450, -90),
        Arc(400, -30),  # a dent into the loop: left, right, left
        Arc(550, 60),
        Arc(400, -30),
        Arc(350, -90),
        Straight(300),  # west side, southbound (free: closes the loop)
        Arc(450, -90),
    ]
    loop, (height, width) = fit_canvas(closed_loop(pieces, free=(0, 8)), ROAD_LANE_PX)
    image = np.zeros((height, width, 3), np.uint8)
    draw_two_lane_road(image, loop, edge=WHITE, centre=YELLOW, dash_px=60)
    crossing = loop.index_in(0, 0.5)
    draw_crosswalk(image, loop, crossing, ROAD_LANE_PX, MAGENTA)
    stop_offset = round(140 / SAMPLE_STEP_PX)  # crosswalk middle to stop line: 140 px
    draw_stop_line(image, loop, crossing - stop_offset, ROAD_LANE_PX, +1, RED)
    draw_stop_line(image, loop, crossing + stop_offset, ROAD_LANE_PX, -1, RED)
    trajectory = loop.offset(ROAD_LANE_PX / 2)
    draw_solid_line(image, trajectory, GREEN, TRAJECTORY_PX)
    spawns = spawns_on(loop, trajectory, [loop.index_in(0, 0.15), loop.index_in(5, 0.5)])
    text = track_yaml(
        "Segmented road markings: a two-lane road, one pure colour per marking class.",
        [
            "Colours (BGR): white [255,255,255] solid edge lines; yellow [0,255,255] dashed",
            "centre line; red [0,0,255] stop lines; magenta [255,0,255] crosswalk;",
            "green [0,255,0] trajectory (middle of the right lane); black: road and ground.",
        ],
        [
            Obstacle(WHITE, -1, "solid edge lines"),
            Obstacle(YELLOW, -1, "dashed centre line"),
        ],
        GREEN,
        "segmented.png",
        spawns,
    )
    write_track(out_dir / "segmented", "segmented.png", image, text)


def formula_student_track(out_dir: Path) -> None:
    """Cone track, driven clockwise on screen: blue cones left, yellow cones right."""
    half_width = 145.0  # trajectory to cone centres [px]
    pieces: list[Piece] = [
        Straight(600),  # north side, eastbound (free: closes the loop)
        Arc(450, 30),  # a chicane: right, then left
        Arc(450, -30),
        Straight(200),
        Arc(450, 90),
        Straight(300),
        Arc(420, 90),
        Straight(50),
        Arc(420, 40),  # a dent into the loop: right, left, right
        Arc(420, -80),
        Arc(420, 40),
        Straight(50),
        Arc(420, 90),
        Straight(400),  # west side, northbound (free: closes the loop)
        Arc(450, 90),
    ]
    loop, (height, width) = fit_canvas(closed_loop(pieces, free=(0, 13)), half_width)
    image = np.zeros((height, width, 3), np.uint8)
    draw_cones(image, loop.offset(-half_width), BLUE, spacing_px=120, radius=12)
    draw_cones(image, loop.offset(half_width), YELLOW, spacing_px=120, radius=12)
    draw_solid_line(image, loop.points, WHITE, TRAJECTORY_PX)
    spawns = spawns_on(loop, loop.points, [loop.index_in(0, 0.5), loop.index_in(9, 0.5)])
    text = track_yaml(
        "Formula Student: cones mark the edges of the track.",
        [
            "Colours (BGR): blue [255,0,0] cones on the left, yellow [0,255,255] cones on the",
            "right of the driving direction; white [255,255,255] trajectory; black: ground.",
        ],
        [
            Obstacle(BLUE, -1, "left cones"),
            Obstacle(YELLOW, -1, "right cones"),
        ],
        WHITE,
        "formula_student.png",
        spawns,
    )
    write_track(out_dir / "formula_student", "formula_student.png", image, text)


def carolo_cup_track(out_dir: Path) -> None:
    """Carolo-Cup road, driven anticlockwise on screen, with boxes blocking the left lane."""
    pieces: list[Piece] = [
        Straight(800),  # south side, eastbound (free: closes the loop)
        Arc(400, -90),
        Straight(200),
        Arc(350, -90),
        Straight(250),
        Arc(600, 25),  # an S-bend: right, then left
        Straight(100),
        Arc(450, -25),
        Straight(150),
        Arc(350, -90),
        Straight(300),  # west side, southbound (free: closes the loop)
        Arc(450, -90),
    ]
    loop, (height, width) = fit_canvas(closed_loop(pieces, free=(0, 10)), ROAD_LANE_PX)
    image = np.zeros((height, width, 3), np.uint8)
    draw_two_lane_road(image, loop, edge=WHITE, centre=WHITE, dash_px=100)
    left_lane = loop.offset(-ROAD_LANE_PX / 2)
    for piece, fraction in [(0, 0.75), (4, 0.5), (10, 0.5)]:
        i = loop.index_in(piece, fraction)
        draw_box(image, left_lane[i], float(loop.headings[i]), (150.0, 120.0), RED)
    trajectory = loop.offset(ROAD_LANE_PX / 2)
    draw_solid_line(image, trajectory, GREEN, TRAJECTORY_PX)
    spawns = spawns_on(loop, trajectory, [loop.index_in(0, 0.2), loop.index_in(6, 0.5)])
    text = track_yaml(
        "Carolo-Cup: white road markings on a black surface.",
        [
            "Colours (BGR): white [255,255,255] solid outer lines and dashed centre line;",
            "red [0,0,255] obstacle boxes in the left lane; green [0,255,0] trajectory",
            "(middle of the right lane); black: road surface.",
        ],
        [Obstacle(RED, "done", "obstacle boxes (end the episode)")],
        GREEN,
        "carolo_cup.png",
        spawns,
    )
    write_track(out_dir / "carolo_cup", "carolo_cup.png", image, text)


def main(argv: list[str]) -> None:
    """Write all example tracks into argv[1], or into the folder of this script."""
    out_dir = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parent
    segmented_track(out_dir)
    formula_student_track(out_dir)
    carolo_cup_track(out_dir)
    sibling = Path(__file__).resolve().with_name("make_metric_tracks.py")  # run or imported
    runpy.run_path(str(sibling))["main"](out_dir)


if __name__ == "__main__":
    main(sys.argv)
