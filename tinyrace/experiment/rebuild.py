"""``tinyrace report RUN_DIR``: rebuild the report of a run folder, one car's or a race's."""

from __future__ import annotations

from pathlib import Path

from tinyrace.experiment.race_report import write_race_report
from tinyrace.experiment.report import write_report
from tinyrace.experiment.run_folder import read_cars, read_episodes, read_header


def rebuild_report(run_dir: Path) -> Path:
    """Rebuild ``report.html`` and its pictures from a run folder's files (checked: a
    ConfigError names the file, the field and what was expected). A race's results.json
    lists its ``cars``; its episodes.csv has a row per car and episode."""
    header = read_header(run_dir)
    tracks = list(header.get("tracks") or {})
    if "cars" in header:
        names = [str(car["id"]) for car in header["cars"]]
        return write_race_report(run_dir, header, read_cars(run_dir, names, tracks))
    return write_report(run_dir, header, read_episodes(run_dir, tracks))
