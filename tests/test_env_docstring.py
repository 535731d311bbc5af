"""TinyRaceEnv's docstring names every built-in track type and car model (it named two of
each once, after there were five and four)."""

from __future__ import annotations

import pytest

from tinyrace.cars.registry import CAR_MODELS
from tinyrace.env import TinyRaceEnv
from tinyrace.tracks.registry import TRACK_SOURCES

DOC = TinyRaceEnv.__doc__ or ""


@pytest.mark.parametrize("name", sorted(TRACK_SOURCES))
def test_the_docstring_names_each_track_type(name: str) -> None:
    assert f"``{name}``" in DOC


@pytest.mark.parametrize("name", sorted(CAR_MODELS))
def test_the_docstring_names_each_car_model(name: str) -> None:
    assert f"``{name}``" in DOC
