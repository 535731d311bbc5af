"""Registered is known: the config layer knows every built-in part's config before any
registry is imported; a part registered before ``gym.make`` (by the user's code, or by a
plugin's entry point in the group ``tinyrace.parts``, loaded by ``import tinyrace``) is
known to config loading, ``tinyrace validate`` and the generated YAML reference."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# A plugin as a third party ships it: a module and an installed distribution whose
# entry point (group tinyrace.parts) names the function that registers its parts.
PLUGIN = '''
from dataclasses import dataclass
from typing import Literal

import numpy as np
from gymnasium import spaces

from tinyrace.config.knobs import REQUIRED, knob
from tinyrace.config.sensors import SensorDefaults
from tinyrace.sensors.base import SensorType
from tinyrace.sensors.registry import register as register_sensor


@dataclass(frozen=True)
class ClockConfig(SensorDefaults):
    """``sensors[i]`` of ``type: sim_clock``: the episode's sim time."""

    id: str = knob(REQUIRED, "observation key of this sensor")
    type: Literal["sim_clock"] = knob("sim_clock", "sensor type")
    scale: float = knob(1.0, "the time is multiplied by it", low=0.0, high=10.0)


class Clock:
    def __init__(self, config):
        self.id, self.scale = config.id, config.scale
        self.space = spaces.Box(0.0, np.inf, (1,), np.float64)

    def reset(self, track):
        pass

    def observe(self, snapshot, track, rng):
        return np.array([snapshot.t * self.scale])

    def describe(self):
        return "the sim time"

    def top_down(self, snapshot, track):
        return None


def register():
    register_sensor(SensorType("sim_clock", ClockConfig, lambda e, c: Clock(e), doc="sim time"))
'''


def _distribution(folder: Path, name: str, module: str, entry: str) -> None:
    """An installed distribution ``name`` in ``folder`` (a ``.dist-info``), with
    ``module``'s source as ``<name>.py`` and one entry point ``entry`` (``x = mod:attr``)."""
    (folder / f"{name}.py").write_text(module)
    info = folder / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[tinyrace.parts]\n{entry}\n")


def _run(script: str, *paths: Path) -> subprocess.CompletedProcess[str]:
    path = os.pathsep.join([str(ROOT), *map(str, paths)])
    environ = {**os.environ, "PYTHONPATH": path}
    return subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environ, timeout=300
    )


def test_every_built_in_part_is_known_to_the_config_layer_before_its_registry() -> None:
    """``import tinyrace`` stays light (tests/test_carracing_env.py), yet the config layer
    knows every built-in track type and sensor type that the registries, once imported,
    hold: config loading accepts them without a registry imported by hand."""
    script = (
        "import json, sys, tinyrace\n"
        "from tinyrace.config import families, load_env_config\n"
        "from tinyrace.config.sensors import SensorConfig\n"
        "from tinyrace.config.tracks import TrackFacts\n"
        "config = load_env_config({'sensors': [{'id': 'l', 'type': 'lidar'}]}).config\n"
        "early = 'tinyrace.sensors.registry' in sys.modules\n"
        "known = {'sensors': sorted(families.members(SensorConfig)), "
        "'tracks': sorted(families.members(TrackFacts))}\n"
        "tinyrace.load_parts()\n"
        "from tinyrace.sensors.registry import SENSOR_TYPES\n"
        "from tinyrace.tracks.registry import TRACK_SOURCES\n"
        "from tinyrace.episodes.rules import RULES\n"
        "from tinyrace.cars.registry import CAR_MODELS\n"
        "from tinyrace.drivers import DRIVERS\n"
        "print(json.dumps({**known, 'early': early, 'loaded': config.sensors[0].type, "
        "'registry_sensors': sorted(SENSOR_TYPES), 'registry_tracks': sorted(TRACK_SOURCES), "
        "'rules': sorted(RULES), 'models': sorted(CAR_MODELS), 'drivers': sorted(DRIVERS)}))\n"
    )
    done = _run(script)
    assert done.returncode == 0, done.stderr
    known = json.loads(done.stdout.strip().splitlines()[-1])
    assert known["loaded"] == "lidar" and known["early"] is False
    assert known["sensors"] == known["registry_sensors"] and "lidar" in known["sensors"]
    assert known["tracks"] == known["registry_tracks"] and "ros_map" in known["tracks"]
    assert {"tile_touches", "playfield", "collisions", "clock", "laps"} <= set(known["rules"])
    assert {"dynamic", "kinematic", "single_track"} <= set(known["models"])
    assert "centerline" in known["drivers"]


def test_a_plugins_entry_point_registers_its_part_before_gym_make(tmp_path: Path) -> None:
    _distribution(tmp_path, "toyclock", PLUGIN, "sim_clock = toyclock:register")
    track = tmp_path / "track.yaml"
    track.write_text("sensors:\n  - {id: t, type: sim_clock, scale: 2.0}\n")
    script = (
        "import json, gymnasium as gym, numpy as np, tinyrace\n"
        "from tinyrace.config.reference import sections\n"
        "from tinyrace.validate import validate_path\n"
        "env = gym.make('tinyrace/TinyRace-v0', sensors=[{'id': 't', 'type': 'sim_clock', "
        "'scale': 2.0}])\n"
        "observation, _ = env.reset(seed=0)\n"
        "observation, *_ = env.step(env.action_space.sample())\n"
        "problems, summary = validate_path(__import__('pathlib').Path(r'TRACK'))\n"
        "titles = [title for title, _, _ in sections()]\n"
        "print(json.dumps({'plugins': tinyrace.load_plugins(), 't': float(observation['t'][0]),"
        " 'dt': env.unwrapped.dt, 'problems': problems, 'reference': "
        "'sensors[i]: type sim_clock' in titles}))\n"
    ).replace("TRACK", str(track))
    done = _run(script, tmp_path)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["plugins"] == ["sim_clock"]
    assert result["t"] == pytest.approx(2.0 * 2 * result["dt"])  # reset's step and one more
    assert result["problems"] == [] and result["reference"] is True


def test_a_plugins_bad_knob_is_a_config_error_and_a_broken_plugin_a_warning(
    tmp_path: Path,
) -> None:
    _distribution(tmp_path, "toyclock", PLUGIN, "sim_clock = toyclock:register")
    _distribution(tmp_path, "broken", "raise RuntimeError('no luck')\n", "oops = broken:go")
    script = (
        "import gymnasium as gym, tinyrace\n"
        "from tinyrace.errors import ConfigError\n"
        "try:\n"
        "    gym.make('tinyrace/TinyRace-v0', sensors=[{'id': 't', 'type': 'sim_clock', "
        "'scale': 20}])\n"
        "except ConfigError as exc:\n"
        "    print('ERROR', exc)\n"
    )
    done = _run(script, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "sensors[0].scale" in done.stdout and "<= 10" in done.stdout
    assert "oops" in done.stderr and "no luck" in done.stderr  # named, and the rest loaded


def test_a_rule_part_registered_by_user_code_is_in_the_reference_and_validates(
    tmp_path: Path,
) -> None:
    toy = (ROOT / "tests" / "test_toy_recipes.py").read_text()
    (tmp_path / "toy_rules.py").write_text(toy)
    track = tmp_path / "track.yaml"
    track.write_text("rules:\n  - {type: speed_limit, limit: 50.0}\n")
    script = (
        "import json, tinyrace, toy_rules\n"
        "from pathlib import Path\n"
        "from tinyrace.episodes.rules import register\n"
        "from tinyrace.config.reference import markdown\n"
        "from tinyrace.validate import validate_path\n"
        "before = validate_path(Path(r'TRACK'))[0]\n"
        "register(toy_rules.SPEED_LIMIT)\n"
        "after = validate_path(Path(r'TRACK'))[0]\n"
        "page = markdown()\n"
        "print(json.dumps({'before': before, 'after': after, 'page': 'rules[i]: type "
        "speed_limit' in page and 'steps over the limit that end the episode' in page}))\n"
    ).replace("TRACK", str(track))
    done = _run(script, tmp_path, ROOT / "tests")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert any("rules[0].type" in line for line in result["before"])
    assert result["after"] == [] and result["page"] is True
