"""The example tracks and experiment configs shipped inside the package."""

from __future__ import annotations

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent / "data"
TRACKS_DIR = DATA_DIR / "tracks"  # one tinycarlo track folder per example
CONFIGS_DIR = DATA_DIR / "configs"  # one experiment file per example
DEFAULT_EXPERIMENT = CONFIGS_DIR / "carracing.yaml"
