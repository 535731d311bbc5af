"""Walls as the map has them: a ROS map's walls are its occupied pixels, no fatter.

The measure: points sampled every quarter pixel over every wall shape (edges included),
each one's distance to the nearest occupied pixel (the pixel's whole square). Before, the
walls were bounding boxes per 4x4 block and reached up to 14 cm (2.2 px) past an occupied
pixel on f1tenth_gym's example map; now they are whole-pixel rectangles.

And what it is for: f1tenth_gym's example map and raceline (tests/data/f1tenth_example,
MIT), driven by a pure pursuit (lookahead 2.0 m, wheelbase 0.3302 m, 6 m/s, from the
first raceline point, at f1tenth_gym's 100 Hz) laps without touching a wall, in about the
26.79 s it takes in f1tenth_gym (racing.md: measured with f1tenth_gym's own code).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.examples import TRACKS_DIR
from tinyrace.tracks.centerline_csv import read_loop
from tinyrace.tracks.ros_map import OccupancyMap, pixel_rects, read_map

DATA = Path(__file__).parent / "data" / "f1tenth_example"
F1TENTH_LAP = 26.79  # [s] f1tenth_gym's pure pursuit lap on its example map (racing.md)
WINDOW = 3  # [px] pixels each side of a sample searched for the nearest occupied square


def overreach(occupancy: OccupancyMap, quads: np.ndarray, per_px: int = 4) -> float:
    """[px] the largest distance from a point of any wall quad to the nearest occupied
    pixel's square, over points ``1 / per_px`` pixels apart covering each quad."""
    corners = occupancy.to_pixel(quads.reshape(-1, 2)).reshape(-1, 4, 2)  # (row, col)
    worst = 0.0
    padded = np.pad(occupancy.occupied, WINDOW)
    offsets = np.arange(-WINDOW, WINDOW + 1)
    for quad in corners:
        side_u, side_v = quad[1] - quad[0], quad[3] - quad[0]
        steps_u = math.ceil(np.hypot(*side_u) * per_px) + 1
        steps_v = math.ceil(np.hypot(*side_v) * per_px) + 1
        u, v = np.meshgrid(np.linspace(0, 1, steps_u), np.linspace(0, 1, steps_v))
        points = quad[0] + u.reshape(-1, 1) * side_u + v.reshape(-1, 1) * side_v  # (P, 2)
        home = np.rint(points).astype(int)
        rows = home[:, 0, None, None] + offsets[:, None]  # (P, 7, 1)
        cols = home[:, 1, None, None] + offsets[None, :]  # (P, 1, 7)
        occupied = padded[rows + WINDOW, cols + WINDOW]  # (P, 7, 7)
        d_row = np.maximum(np.abs(points[:, 0, None, None] - rows) - 0.5, 0)
        d_col = np.maximum(np.abs(points[:, 1, None, None] - cols) - 0.5, 0)
        distance = np.where(occupied, np.hypot(d_row, d_col), WINDOW + 0.5)
        worst = max(worst, float(distance.min(axis=(1, 2)).max()))
    return worst


def old_block_boxes(occupancy: OccupancyMap, cell: int = 4) -> np.ndarray:
    """(M, 4, 2) the walls as they were: the bounding box of the occupied pixels of each
    4x4 block (yaw 0), for the before/after figure."""
    quads = []
    h, w = occupancy.shape
    for top in range(0, h, cell):
        for left in range(0, w, cell):
            rows, cols = np.nonzero(occupancy.occupied[top : top + cell, left : left + cell])
            if len(rows):
                r0, r1 = top + rows.min() - 0.5, top + rows.max() + 0.5
                c0, c1 = left + cols.min() - 0.5, left + cols.max() + 0.5
                corners = occupancy.to_world(np.array([r1, r1, r0, r0]), np.array([c0, c1, c1, c0]))
                quads.append(corners)
    return np.array(quads)


MAPS = [DATA / "example_map.yaml", TRACKS_DIR / "f1tenth_loop" / "map.yaml"]


@pytest.mark.parametrize("path", MAPS, ids=["f1tenth_example", "f1tenth_loop"])
def test_walls_reach_no_further_than_the_occupied_pixels(path):
    occupancy = read_map(path, "t", "k")
    quads = occupancy.wall_quads()
    assert overreach(occupancy, quads) < 1e-6  # [px]: on the pixels' own edges
    assert overreach(occupancy, old_block_boxes(occupancy)) > 1.0  # the measure sees fat walls


def test_the_rectangles_cover_every_occupied_pixel_once():
    occupancy = read_map(DATA / "example_map.yaml", "t", "k")
    rects = pixel_rects(occupancy.occupied)
    covered = np.zeros(occupancy.shape, int)
    for r0, c0, r1, c1 in rects:
        covered[r0 : r1 + 1, c0 : c1 + 1] += 1
    assert (covered == occupancy.occupied).all()  # every occupied pixel once, nothing else
    assert len(rects) < occupancy.occupied.sum() / 5  # merged: few shapes for the physics


def test_a_rotated_map_turns_its_walls_with_it(tmp_path):
    for name in ("map.yaml", "map.png"):
        shutil.copy(TRACKS_DIR / "f1tenth_loop" / name, tmp_path / name)
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_path.read_text().replace("0.0]", "0.4]"))
    occupancy = read_map(yaml_path, "t", "k")
    assert occupancy.info.origin[2] == 0.4
    assert overreach(occupancy, occupancy.wall_quads()) < 1e-6


def pure_pursuit(points: np.ndarray, pose: tuple[float, float, float], lookahead: float) -> float:
    """[rad] the front-wheel angle (+ left) that aims the car at the point of the closed
    line ``points`` ``lookahead`` [m] ahead of the nearest point."""
    x, y, heading = pose
    n = len(points)
    start = int(np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - y)))
    goal = points[start]
    for k in range(n):
        a, b = points[(start + k) % n], points[(start + k + 1) % n]
        if math.hypot(b[0] - x, b[1] - y) >= lookahead:  # the circle leaves through a-b
            along, offset = b - a, a - (x, y)
            qa, qb, qc = along @ along, 2 * offset @ along, offset @ offset - lookahead**2
            t = (-qb + math.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa)
            goal = a + min(max(t, 0.0), 1.0) * along
            break
    lateral = -math.sin(heading) * (goal[0] - x) + math.cos(heading) * (goal[1] - y)
    return math.atan(0.3302 * 2.0 * lateral / lookahead**2)


@pytest.mark.slow  # 2,700 steps
def test_a_pure_pursuit_laps_f1tenths_example_map_as_in_f1tenth_gym():
    points = read_loop(DATA / "example_waypoints.csv", "t", "k").points
    fps = 100.0  # [Hz] f1tenth_gym's
    env = gym.make(
        "tinyrace/TinyRace-v0",
        config=str(DATA / "track.yaml"),
        sim={"fps": fps, "step_limit": 4000},
    )
    _, info = env.reset(seed=0)
    assert info["pose"][:2] == pytest.approx(points[0])  # from the first raceline point
    for step in range(4000):
        steer = pure_pursuit(points, info["pose"], 2.0)
        _, _, terminated, truncated, info = env.step(np.array([steer, 6.0], np.float32))
        assert info["walls_hit"] == 0, f"a wall at {(step + 1) / fps:.2f} s, {info['pose']}"
        if terminated or truncated:
            break
    assert info.get("lap_finished"), info
    assert (step + 1) / fps == pytest.approx(F1TENTH_LAP, rel=0.01)
