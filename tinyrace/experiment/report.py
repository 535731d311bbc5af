"""``report.html`` for a run folder: self-contained (pictures inline as data URIs, no network,
no JavaScript), with the pictures also saved beside it. Built from the run's files only
(results.json, episodes.csv, the traces and track pictures), so ``tinyrace report RUN_DIR``
rebuilds it."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tinyrace.config.image_file import DEFAULT_MAX_IMAGE_PIXELS, read_image_bgr
from tinyrace.experiment import plots
from tinyrace.experiment.results import (
    EPISODES_FILE,
    RESULTS_FILE,
    EpisodeResult,
    summary_text,
    table,
)
from tinyrace.experiment.run_folder import check_outputs, read_episodes, read_header, read_trace
from tinyrace.render.track_picture import PictureFrame

REPORT_FILE = "report.html"
CRASHES = ("out_of_bounds", "obstacle")


def rebuild_report(run_dir: Path) -> Path:
    """Rebuild ``report.html`` and its pictures from a run folder's files (checked: a
    ConfigError names the file, the field and what was expected)."""
    header = read_header(run_dir)
    return write_report(run_dir, header, read_episodes(run_dir))


def _inputs(header: dict[str, Any], results: Sequence[EpisodeResult]) -> dict[str, str]:
    """The run files the report reads, each with the file that names it."""
    names = {RESULTS_FILE: RESULTS_FILE, EPISODES_FILE: EPISODES_FILE}
    names |= {name: EPISODES_FILE for r in results for name in (r.trace, r.video) if name}
    tracks = (header.get("tracks") or {}).values()
    return names | {entry["image"]: RESULTS_FILE for entry in tracks}


def write_report(run_dir: Path, header: dict[str, Any], results: Sequence[EpisodeResult]) -> Path:
    """Draw the pictures, save them as PNG and write report.html; returns its path.

    Refused (a ConfigError) when one of the files to write is one the report reads."""
    outputs = [REPORT_FILE, "report_returns.png", "report_lap_times.png"]
    outputs += [f"report_track_{key}.png" for key in header.get("tracks") or {}]
    outputs += [f"report_episode_{r.episode:03d}.png" for r in results if r.trace]
    check_outputs(run_dir, outputs, _inputs(header, results))
    pictures = _track_pictures(run_dir, header, results)
    labels = [str(r.episode) for r in results]
    pictures.append(
        ("report_returns.png", "Return per episode",
         plots.bar_chart([r.episode_return for r in results], labels, "return per episode"))
    )  # fmt: skip
    pictures.append(
        ("report_lap_times.png", "Lap time per episode (no bar: no lap finished)",
         plots.bar_chart([r.lap_time for r in results], labels, "lap time [s]"))
    )  # fmt: skip
    unit = _unit(header)
    for result in results:
        trace = _trace(run_dir, result)
        if trace is None:
            continue
        panels = [
            (f"speed [{unit}/s]", trace["speed"]),
            ("steering (-1 left .. +1 right)", trace["steer"]),
            (f"cross-track error [{unit}]", trace["cte"]),
        ]
        title = f"episode {result.episode} (seed {result.seed}): {result.end}"
        name = f"report_episode_{result.episode:03d}.png"
        pictures.append((name, title, plots.time_series(trace["t"], panels, title)))
    blobs = []
    for name, caption, image in pictures:
        _, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        (run_dir / name).write_bytes(data.tobytes())
        blobs.append((caption, data.tobytes()))
    path = run_dir / REPORT_FILE
    path.write_text(_html(header, results, blobs), encoding="utf-8")
    return path


def _unit(header: dict[str, Any]) -> str:
    """The track's unit: CarRacing's u, image pixels, or metres on the metric kinds."""
    kind = str(header.get("track_kind"))
    return {"procedural": "u", "centerline": "m", "cone_map": "m", "ros_map": "m"}.get(kind, "px")


def _trace(run_dir: Path, result: EpisodeResult) -> dict[str, np.ndarray] | None:
    path = run_dir / result.trace if result.trace else None
    return read_trace(path) if path is not None and path.is_file() else None


def _background(run_dir: Path, key: str, name: str) -> np.ndarray | None:
    """A track picture of the run folder (None when missing), read within the pixel cap."""
    path = run_dir / name
    if not path.is_file():
        return None
    where = f"tracks.{key}.image"
    return read_image_bgr(path, DEFAULT_MAX_IMAGE_PIXELS, str(run_dir / RESULTS_FILE), where)


def _on_picture(pixels: np.ndarray) -> np.ndarray:
    """Pixel positions clipped to a band around the picture (hand-edited frames may send them
    to 1e300); NaN stays NaN (not drawn)."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.asarray(np.clip(pixels, -PIXEL_BAND, PIXEL_BAND), np.float64)


PIXEL_BAND = 1e5  # [px] how far off the picture a drawn position may lie


def _track_pictures(
    run_dir: Path, header: dict[str, Any], results: Sequence[EpisodeResult]
) -> list[tuple[str, str, np.ndarray]]:
    """One picture per track with the trajectories of the episodes run on it."""
    pictures = []
    tracks: dict[str, Any] = header.get("tracks") or {}
    for key, entry in tracks.items():
        background = _background(run_dir, key, entry["image"])
        if background is None:
            continue
        frame = PictureFrame(*entry["frame"]).pixels
        paths = []
        for result in (r for r in results if r.track == key):
            trace = _trace(run_dir, result)
            if trace is None:
                continue
            points = _on_picture(frame(np.stack([trace["x"], trace["y"]], axis=-1)))
            crashed = result.end in CRASHES
            hits = trace["obstacle_hit"] > 0
            paths.append(
                plots.Path2D(f"ep {result.episode}", points, trace["speed"], hits, crashed)
            )
        lap = None if entry.get("lap_line") is None else frame(np.array(entry["lap_line"]))
        lap = None if lap is None or not np.isfinite(lap).all() else _on_picture(lap)
        image = plots.trajectories(background[..., ::-1], paths, lap, entry.get("unit", ""))
        episodes = ", ".join(p.label.removeprefix("ep ") for p in paths) or "none"
        caption = (
            f"Track {key}: episodes {episodes}. Colour: speed; green dot: start; "
            "white line: lap line; red X: crash; orange rings: obstacle hits."
        )
        pictures.append((f"report_track_{key}.png", caption, image))
    return pictures


def _html(
    header: dict[str, Any], results: Sequence[EpisodeResult], blobs: list[tuple[str, bytes]]
) -> str:
    title = f"tinyrace run {header.get('started', '')}"
    state = []
    if header.get("interrupted"):
        state.append(f"<p class=warn>Interrupted by {html.escape(str(header.get('signal')))}.</p>")
    if header.get("error"):
        state.append(f"<p class=warn>Stopped by an error: {html.escape(header['error'])}</p>")
    planned = header.get("episodes_planned", len(results))
    figures = "\n".join(
        f"<figure class={'wide' if caption.startswith('Track') else 'small'}>"
        f"<img alt='{html.escape(caption)}' "
        f"src='data:image/png;base64,{base64.b64encode(data).decode()}'>"
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        for caption, data in blobs
    )
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: sans-serif; margin: 2em; color: #222; }}
pre {{ background: #f4f4f4; padding: 1em; overflow-x: auto; }}
img {{ max-width: 100%; border: 1px solid #ccc; }}
figure {{ margin: 1.5em 1em 1.5em 0; }} .warn {{ color: #b00; font-weight: bold; }}
figure.small {{ display: inline-block; vertical-align: top; max-width: 560px; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
<p>Experiment: {html.escape(str(header.get("experiment", "")))};
{len(results)} of {planned} episode(s) finished; track kind: {header.get("track_kind", "?")}.</p>
{"".join(state)}
<h2>Episodes</h2>
<pre>{html.escape(table(results))}</pre>
<h2>Summary (mean ± std)</h2>
<pre>{html.escape(summary_text(header.get("summary") or {}))}</pre>
<h2>Pictures</h2>
{figures}
</body></html>
"""
