"""``gym.make(environment=..., config=..., **keywords)``: the folder's track.yaml, then
``config=`` laid over it, then the keywords over both; a bad key names where it came from."""

from __future__ import annotations

from pathlib import Path

import pytest

from tinyrace.config import load_env_config
from tinyrace.errors import ConfigError


def test_config_is_laid_over_the_folder_and_keywords_over_both(tmp_path: Path):
    (tmp_path / "short.yaml").write_text("sim: {step_limit: 200, fps: 25}\n")
    folder = load_env_config(environment="formula_student").config
    loaded = load_env_config(tmp_path / "short.yaml", "formula_student", {"sim": {"fps": 50}})
    config = loaded.config
    assert (config.sim.step_limit, config.sim.fps) == (200, 50)
    assert config.tracks == folder.tracks and config.car == folder.car  # the rest: the folder's
    as_dict = load_env_config({"sim": {"step_limit": 7}}, "formula_student").config
    assert as_dict.sim.step_limit == 7 and as_dict.sim.fps == folder.sim.fps


def test_a_bad_key_of_config_names_the_file_and_with_keywords_both(tmp_path: Path):
    (tmp_path / "bad.yaml").write_text("sim: {fps: -2}\n")
    with pytest.raises(ConfigError) as alone:
        load_env_config(tmp_path / "bad.yaml", "formula_student")
    assert f"{tmp_path / 'bad.yaml'}: sim.fps: got -2" in str(alone.value)
    with pytest.raises(ConfigError) as both:
        load_env_config(tmp_path / "bad.yaml", "formula_student", {"sim": {"step_limit": 9}})
    assert f"{tmp_path / 'bad.yaml'} + <kwargs>: sim.fps: got -2" in str(both.value)
