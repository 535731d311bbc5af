"""``track.type: procedural``: CarRacing's track, drawn anew from the env's rng per reset.

``ProceduralSource.draw`` holds CarRacing's reset order of random numbers (colours when
randomised, then the track); the env and ``tinyrace show`` both call it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tinyrace import kernels
from tinyrace.config import EnvConfig, ProceduralTrackConfig
from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.base import PaintedGround, Surface, Track, TrackDraw, TrackRules
from tinyrace.tracks.procedural import (
    NoClosedLap,
    ProceduralTrack,
    ProceduralTrackParams,
    generate_track,
    trace_path,
)

GRASS_FRICTION = 0.6  # CarRacing's grip off the road, as a fraction of the road's
RANDOM_COLOR_HIGH = 210  # domain randomisation: road and background channels uniform(0, 210)
RANDOM_GRASS_SHIFT = 20  # ... and the grass is the background + 20 on one channel
_NO_LAP = (
    "expected knobs that close a lap: a smaller radius, a longer detail_step "
    "or a larger turn_rate (the track generator found no closed lap)"
)


@dataclass(frozen=True)
class GroundColors:
    """RGB colours of one episode (domain randomisation redraws them)."""

    road: np.ndarray  # (3,) float: the tile colours add a small shade to it
    background: np.ndarray
    grass: np.ndarray

    @classmethod
    def of(cls, track: Track) -> GroundColors:
        """The colours of a track's palette (the same floats as those it was drawn with)."""
        road, background, grass = (
            np.array(track.palette[name], float) for name in ("road", "background", "grass")
        )
        return cls(road, background, grass)


def track_params(config: ProceduralTrackConfig) -> ProceduralTrackParams:
    """The generator's knobs from the ``track`` section."""
    return ProceduralTrackParams(
        checkpoints=config.checkpoints,
        radius=config.radius,
        half_width=config.half_width,
        turn_rate=config.turn_rate,
        detail_step=config.detail_step,
        border=config.border,
        border_min_count=config.border_min_count,
    )


def draw_colors(rng: np.random.Generator) -> GroundColors:
    """Domain randomisation: road, background uniform(0, 210); grass +20 on one channel."""
    road = rng.uniform(0, RANDOM_COLOR_HIGH, size=3)
    background = rng.uniform(0, RANDOM_COLOR_HIGH, size=3)
    grass = background.copy()
    grass[rng.integers(3)] += RANDOM_GRASS_SHIFT
    return GroundColors(road, background, grass)


def config_colors(config: ProceduralTrackConfig) -> GroundColors:
    """The configured colours (no randomisation)."""
    return GroundColors(
        np.array(config.road_color, float),
        np.array(config.background_color, float),
        np.array(config.grass_color, float),
    )


TRACE_VARIABLE = "TINYRACE_TRACE"  # environment variable: auto | numba | python
Trace = Callable[[np.ndarray, ProceduralTrackParams], np.ndarray]


def trace_kernel(wanted: str | None = None) -> tuple[str, Trace]:
    """(path name, tracer of CarRacing's path) that ``wanted`` names (auto | numba | python;
    None: ``TINYRACE_TRACE``'s value, else auto): the compiled ``kernels/procedural.py`` when
    numba imports, else the Python loop. The same tracks bit for bit."""
    name, module = kernels.choose(
        TRACE_VARIABLE, "python", "tinyrace.tracks.kernels.procedural", wanted
    )
    return name, trace_path if module is None else module.trace_path


class ProceduralSource:
    """``track.type: procedural``: a new CarRacing track per reset.

    ``colors`` are the last episode's: a reset with ``randomize: False`` keeps them.
    """

    kind = "procedural"
    tracks: tuple[Track, ...] = ()  # a new track at every reset

    def __init__(self, config: EnvConfig, base_dir: Path | None = None, source: str = ""):
        track = config.tracks[0]
        assert isinstance(track, ProceduralTrackConfig)
        self.config = track
        self.painted: PaintedGround | None = PaintedGround(track.playfield, track.pixels_per_unit)
        self.source = source
        self.params = track_params(self.config)
        self.colors = config_colors(self.config)
        self.kernel: str | None = None  # the path's tracer (numba | python), at the first draw
        self._trace: Trace | None = None

    def draw(self, rng: np.random.Generator, options: Mapping[str, object]) -> TrackDraw:
        """CarRacing's reset order: colours (when randomised) are drawn before the track.

        There is one track and one start: the options ``track`` and ``spawn`` may only be
        0 or None."""
        _check_one(options)
        if self.config.domain_randomize and options.get("randomize", True):
            self.colors = draw_colors(rng)
        try:
            generated = generate_track(rng, self.params, self._trace or self._choose_trace())
        except NoClosedLap as exc:
            c = self.config
            knobs = {"radius": c.radius, "detail_step": c.detail_step, "turn_rate": c.turn_rate}
            raise ConfigError(Problem(self.source, "tracks[0]", knobs, _NO_LAP)) from exc
        return TrackDraw(self.track(generated), 0, 0)

    def _choose_trace(self) -> Trace:
        """The tracer's path, chosen at the first draw (``trace_kernel``)."""
        self.kernel, self._trace = trace_kernel()
        return self._trace

    def __getstate__(self) -> dict[str, object]:
        return {**self.__dict__, "_trace": None}  # chosen again after unpickling

    def track(self, generated: ProceduralTrack) -> Track:
        """The generic view of a generated track, in CarRacing's units, y up."""
        x, y, hull_angle = generated.start_pose
        headings = generated.headings + math.pi / 2  # beta is the hull's angle
        headings.setflags(write=False)
        side = self.config.playfield  # [u]
        colors = self.colors
        return Track(
            kind=self.kind,
            unit="u",
            metres_per_unit=None,
            y_down=False,
            bounds=(-side, -side, side, side),
            spawns=((x, y, hull_angle + math.pi / 2),),
            centerline=generated.centerline,
            headings=headings,
            tiles=generated.tiles,
            surfaces=(Surface("road", 1.0, generated.tiles),),
            off_road_friction=GRASS_FRICTION,
            palette={
                "road": _rgb(colors.road),
                "background": _rgb(colors.background),
                "grass": _rgb(colors.grass),
            },
            rules=TrackRules(
                ("tile_touches", "playfield"),
                reset_step=True,  # CarRacing's reset steps the physics once
                lap_complete_percent=self.config.lap_complete_percent,
            ),
            kerbs=generated.kerbs,
            kerb_red=generated.kerb_red,
            painted=self.painted,
            drawn_per_reset=True,
            attempts=generated.attempts,
        )


def _check_one(options: Mapping[str, object]) -> None:
    """The reset options ``track`` and ``spawn``: 0 or None (one track, one start)."""
    for key in ("track", "spawn"):
        value = options.get(key)
        whole = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if value is None or (whole and value == 0):
            continue
        allowed = f"expected 0 or None (a procedural track has one {key})"
        raise ConfigError(Problem("<reset options>", key, value, allowed))


def _rgb(color: np.ndarray) -> tuple[float, float, float]:
    r, g, b = color.tolist()
    return float(r), float(g), float(b)
