"""benchmarks/race.py runs: a tiny run (one round of three steps) prints its table and
writes a row per track, sensor setup and number of cars (no timing is asserted)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import tinyrace

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "race.py"


def test_the_race_benchmark_runs_and_reports_every_case(tmp_path):
    out = tmp_path / "rows.json"
    command = [sys.executable, str(SCRIPT), "--rounds", "1", "--steps", "3", "--cars", "1", "2"]
    command += ["--tracks", "f1tenth_loop", "procedural", "--json", str(out)]
    here = Path(tinyrace.__file__).resolve().parents[1]  # the tinyrace this test imported
    env = {**os.environ, "PYTHONPATH": str(here)}
    done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "| track | sensors | cars |" in done.stdout
    rows = json.loads(out.read_text())
    cases = {(row["track"], row["setup"], row["cars"]) for row in rows}
    tracks, setups = ("f1tenth_loop", "procedural"), ("lidar", "camera")
    assert cases == {(t, s, n) for t in tracks for s in setups for n in (1, 2)}
    for row in rows:
        assert row["car_steps"] == row["cars"]  # every car raced every step
        for key in ("single_us", "per_car_us", "ratio"):
            assert math.isfinite(row[key]) and row[key] > 0, row
