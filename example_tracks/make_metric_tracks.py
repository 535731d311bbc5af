"""Generate the three example tracks in metres (called by ``make_example_tracks.py``).

Usage::

    python example_tracks/make_metric_tracks.py [OUT_DIR]

- ``circuit/circuit.csv``: a 2.2 km circuit in the racetrack-database centreline
  format (``# x_m,y_m,w_tr_right_m,w_tr_left_m``), width varying from 9 to 13 m.
- ``autocross/cones.csv``: a small Formula Student autocross as a cone map (blue
  left, yellow right, big orange at the start line, two small orange marks).
- each folder's ``track.yaml``: the track in one line, and a car of the right size.
- ``f1tenth_loop/``: a ROS map_server map (``map.yaml``, ``map.png`` at 0.05 m/px)
  of a walled 2.2 m corridor, with an F1TENTH raceline (``raceline.csv``).

Every shape is a smooth closed curve given by a few harmonics of a polar radius, so
the output is the same on every run and owes nothing to third-party data.
World frame: metres, x right, y up; each loop is driven counter-clockwise.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import cv2
import numpy as np

RESOLUTION = 0.05  # [m/px] of the ROS map
FREE, UNKNOWN, OCCUPIED = 254, 205, 0  # map_server's pixel values (trinary)


def polar_loop(
    count: int, radius: float, harmonics: list[tuple[int, float, float]], stretch: float
) -> np.ndarray:
    """(count, 2) points of r(t) = radius * (1 + sum a cos(k t + phase)), x stretched [m]."""
    t = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    r = radius * (1 + sum(a * np.cos(k * t + phase) for k, a, phase in harmonics))
    return np.column_stack((stretch * r * np.cos(t), r * np.sin(t)))


def even(loop: np.ndarray, spacing: float) -> np.ndarray:
    """The loop resampled ``spacing`` [m] apart (the count rounded to close evenly)."""
    closed = np.vstack((loop, loop[:1]))
    arc = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(closed, axis=0).T))))
    at = np.linspace(0.0, arc[-1], max(round(arc[-1] / spacing), 4), endpoint=False)
    return np.column_stack([np.interp(at, arc, closed[:, k]) for k in (0, 1)])


def left_normals(loop: np.ndarray) -> np.ndarray:
    """(N, 2) unit normals to the left of the driving direction."""
    ahead = np.roll(loop, -1, axis=0) - np.roll(loop, 1, axis=0)
    ahead /= np.hypot(*ahead.T)[:, None]
    return np.column_stack((-ahead[:, 1], ahead[:, 0]))


# -- the circuit: racetrack-database centreline CSV ---------------------------------------------
def circuit_csv(out_dir: Path) -> None:
    dense = polar_loop(4000, 260.0, [(2, 0.22, 0.4), (3, 0.12, 1.3), (5, 0.05, 0.2)], 1.35)
    points = even(dense, 5.0)
    t = np.linspace(0.0, 2 * math.pi, len(points), endpoint=False)
    right = 5.5 + 1.0 * np.sin(3 * t)  # [m]
    left = 5.5 + 1.0 * np.cos(4 * t)  # [m]
    rows = [
        f"{x:.4f},{y:.4f},{r:.4f},{w:.4f}" for (x, y), r, w in zip(points, right, left, strict=True)
    ]
    folder = out_dir / "circuit"
    folder.mkdir(parents=True, exist_ok=True)
    text = "# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows) + "\n"
    (folder / "circuit.csv").write_text(text)


# -- the autocross: Formula Student cone map ----------------------------------------------------
AUTOCROSS_HALF_WIDTH = 2.0  # [m] a 4 m wide lane (the handbook's minimum is 3 m)
CONE_SPACING = 4.0  # [m] along each edge (the handbook's maximum is 5 m)


def autocross_csv(out_dir: Path) -> None:
    centre = even(polar_loop(2000, 28.0, [(2, 0.25, 0.0), (3, 0.1, 0.8)], 1.3), 0.5)
    normal = left_normals(centre)
    rows = ["tag,x,y,direction,x_variance,y_variance,covariance"]
    for tag, side in (("blue", 1.0), ("yellow", -1.0)):
        edge = even(centre + side * AUTOCROSS_HALF_WIDTH * normal, CONE_SPACING)
        rows += [_cone_row(tag, x, y) for x, y in edge[1:]]  # the start line has big cones
    ahead = np.roll(centre, -1, axis=0)[0] - centre[0]
    ahead /= np.hypot(*ahead)
    for along in (-0.5, 0.5):  # two pairs of big orange cones across the start line [m]
        for side in (1.0, -1.0):
            x, y = centre[0] + along * ahead + side * AUTOCROSS_HALF_WIDTH * normal[0]
            rows.append(_cone_row("big_orange", x, y))
    quarter = len(centre) // 4
    for side in (1.0, -1.0):  # small orange marks just outside the lane, a quarter lap on
        x, y = centre[quarter] + side * (AUTOCROSS_HALF_WIDTH + 1.0) * normal[quarter]
        rows.append(_cone_row("orange", x, y))
    folder = out_dir / "autocross"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cones.csv").write_text("\n".join(rows) + "\n")


def _cone_row(tag: str, x: float, y: float) -> str:
    return f"{tag},{x:.3f},{y:.3f},0,0,0,0"


# -- the F1TENTH loop: ROS map and raceline -----------------------------------------------------
CORRIDOR_HALF_WIDTH = 1.1  # [m]
WALL_PX = 3  # [px] wall thickness in the map picture
MAP_MARGIN = 1.0  # [m] unknown cells around the outer wall


def f1tenth_map(out_dir: Path) -> None:
    centre = even(polar_loop(2000, 7.0, [(2, 0.2, 0.0), (3, 0.08, 0.6)], 1.5), 0.1)
    normal = left_normals(centre)
    left, right = centre + CORRIDOR_HALF_WIDTH * normal, centre - CORRIDOR_HALF_WIDTH * normal
    low = np.minimum(left.min(axis=0), right.min(axis=0)) - MAP_MARGIN
    high = np.maximum(left.max(axis=0), right.max(axis=0)) + MAP_MARGIN
    width, height = np.ceil((high - low) / RESOLUTION).astype(int)
    picture = np.full((height, width), UNKNOWN, np.uint8)

    def pixels(points: np.ndarray) -> np.ndarray:  # world [m] -> cv2 points, 4 fractional bits
        col = (points[:, 0] - low[0]) / RESOLUTION - 0.5
        row = height - (points[:, 1] - low[1]) / RESOLUTION - 0.5
        return np.asarray(np.rint(np.column_stack((col, row)) * 16), np.int32)

    outer, inner = (right, left)  # counter-clockwise: the right edge is outside
    cv2.fillPoly(picture, [pixels(outer)], FREE, cv2.LINE_8, shift=4)
    cv2.fillPoly(picture, [pixels(inner)], UNKNOWN, cv2.LINE_8, shift=4)
    for edge in (outer, inner):
        cv2.polylines(picture, [pixels(edge)], True, OCCUPIED, WALL_PX, cv2.LINE_8, shift=4)
    folder = out_dir / "f1tenth_loop"
    folder.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(folder / "map.png"), picture)
    (folder / "map.yaml").write_text(
        "image: map.png\n"
        f"resolution: {RESOLUTION}\n"
        f"origin: [{low[0]:.4f}, {low[1]:.4f}, 0.0]\n"
        "negate: 0\n"
        "occupied_thresh: 0.45\n"
        "free_thresh: 0.196\n"
    )
    (folder / "raceline.csv").write_text(raceline_text(even(centre, 0.2)))


def raceline_text(points: np.ndarray, lateral: float = 4.0, top: float = 6.0) -> str:
    """F1TENTH's raceline CSV of ``points``: speed capped by ``lateral`` [m/s^2], ``top`` [m/s].

    psi is measured from the y axis (F1TENTH's convention): heading - pi / 2.
    """
    ahead = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    heading = np.arctan2(ahead[:, 1], ahead[:, 0])
    step = np.hypot(*(np.roll(points, -1, axis=0) - points).T)
    s = np.concatenate(([0.0], np.cumsum(step)[:-1]))
    turn = np.angle(np.exp(1j * (np.roll(heading, -1) - np.roll(heading, 1))))
    kappa = turn / (step + np.roll(step, 1))
    vx = np.minimum(top, np.sqrt(lateral / np.maximum(np.abs(kappa), 1e-6)))
    ax = (np.roll(vx, -1) ** 2 - vx**2) / (2 * step)
    psi = np.angle(np.exp(1j * (heading - math.pi / 2)))
    lines = [
        "# generated by example_tracks/make_metric_tracks.py",
        "# a raceline along the middle of the corridor",
        "# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2",
    ]
    columns = (s, points[:, 0], points[:, 1], psi, kappa, vx, ax)
    lines += ["; ".join(f"{v:.5f}" for v in row) for row in zip(*columns, strict=True)]
    return "\n".join(lines) + "\n"


# -- track.yaml of each folder ------------------------------------------------------------------
TRACK_YAMLS = {
    "circuit": """\
# A 2.2 km circuit in the racetrack-database centreline format (metres).
# Point it at a real circuit instead: copy racetrack-database/tracks/Monza.csv into this
# folder and write file: Monza.csv, or give the file's own path with
# files: {paths_outside_folder: true} (a path outside this folder is refused otherwise).
track: {type: centerline, file: circuit.csv, spacing: 2.0}   # spacing [m] of the tiles
car:   # a kinematic car with throttle, in metres
  model: kinematic_throttle
  wheelbase: 2.5            # [m]
  track_width: 1.6          # [m]
  velocity: 30.0            # [m/s] top speed
  max_acceleration: 6.0     # [m/s^2]
  max_deceleration: 10.0    # [m/s^2]
  max_steering_angle: 30.0  # [deg]
cameras:   # a bird's-eye camera over the road ahead: roi [ahead, across] in metres
  - {id: front, resolution: [96, 128], roi: [30.0, 40.0], position: [0.0, 0.0]}
sim: {step_limit: 6000}
""",
    "autocross": """\
# A small Formula Student autocross from a cone map (blue left, yellow right, metres).
track: {type: cone_map, file: cones.csv, spacing: 0.5, cone_hit_ends_episode: false}
reward_design: {cone_penalty: 5.0}   # per cone knocked over
car:   # about a Formula Student car
  model: kinematic_throttle
  wheelbase: 1.55           # [m]
  track_width: 1.2          # [m]
  velocity: 15.0            # [m/s] top speed
  max_acceleration: 8.0     # [m/s^2]
  max_deceleration: 12.0    # [m/s^2]
  max_steering_angle: 30.0  # [deg]
cameras:   # roi [ahead, across] in metres: the cones of the next corners
  - {id: front, resolution: [96, 128], roi: [12.0, 16.0], position: [0.0, 0.0]}
sim: {step_limit: 3000}
""",
    "f1tenth_loop": """\
# An F1TENTH-style corridor: a ROS map_server map with a raceline (metres).
track: {type: ros_map, file: map.yaml, waypoints: raceline.csv, wall_hit_ends_episode: false}
reward_design: {wall_penalty: 1.0}   # per step touching a wall
car:   # about an F1TENTH car
  model: kinematic_throttle
  wheelbase: 0.33           # [m]
  track_width: 0.3          # [m]
  velocity: 5.0             # [m/s] top speed
  max_acceleration: 9.51    # [m/s^2]
  max_deceleration: 13.26   # [m/s^2]
  max_steering_angle: 24.0  # [deg]
cameras:   # roi [ahead, across] in metres: the corridor and its walls
  - {id: front, resolution: [96, 128], roi: [3.0, 4.0], position: [0.0, 0.0]}
sim: {step_limit: 2000}
""",
}


def track_yamls(out_dir: Path) -> None:
    for folder, text in TRACK_YAMLS.items():
        (out_dir / folder).mkdir(parents=True, exist_ok=True)
        (out_dir / folder / "track.yaml").write_text(text)


def main(out_dir: Path) -> None:
    """Write the three metric examples into ``out_dir``."""
    circuit_csv(out_dir)
    autocross_csv(out_dir)
    f1tenth_map(out_dir)
    track_yamls(out_dir)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent)
