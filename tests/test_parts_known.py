"""Registered is known: the config layer knows every built-in part's config before any
registry is imported; a part registered before ``gym.make`` (by the user's code, or by a
plugin's entry point in the group ``tinyrace.parts``, loaded by ``import tinyrace``) is
known to config loading, ``tinyrace validate`` and the generated YAML reference."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import tinyrace
from tinyrace.examples import TRACKS_DIR

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


def _run(script: str, *paths: Path | str) -> subprocess.CompletedProcess[str]:
    """``script`` in a fresh interpreter with ``paths`` importable (the Paths; strings are
    its arguments)."""
    folders = [str(p) for p in paths if isinstance(p, Path)]
    arguments = [p for p in paths if isinstance(p, str)]
    environ = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *folders])}
    return subprocess.run(
        [sys.executable, "-c", script, *arguments],
        capture_output=True,
        text=True,
        env=environ,
        timeout=300,
    )


# Each built-in part in a config that uses it: (track folder or None for the procedural
# track, sensor type, car model or None for the track's default, driver). Together they use
# every registered track type, sensor type, car model and driver (checked below).
BUILT_IN_CASES = [
    (None, "chase_view", "dynamic", "random"),
    ("formula_student", "birdseye_camera", "kinematic", "constant"),
    ("carolo_cup", "perspective_camera", None, "centerline"),
    ("circuit", "top_view", "kinematic_throttle", "centerline"),
    ("circuit", "lidar", "single_track", "random"),
    ("autocross", "cones", None, "centerline"),
    ("f1tenth_loop", "state", "single_track", "constant"),
    ("circuit", "lookahead", None, "centerline"),
    ("segmented", "opponents", None, "centerline"),
]

# In a fresh interpreter that only imported tinyrace: each case loaded through the config
# layer and validated as ``tinyrace validate`` does (an experiment file naming the track,
# the sensor, the car model and the driver), then the generated reference; which registry
# modules ``import tinyrace`` had imported is printed first.
BUILT_IN_SCRIPT = """
import json, sys
from pathlib import Path
import tinyrace
from tinyrace.examples import TRACKS_DIR
registries = ["tinyrace.cars.registry", "tinyrace.sensors.registry", "tinyrace.drivers",
              "tinyrace.tracks.registry", "tinyrace.episodes.rules", "tinyrace.config"]
imported = [name for name in registries if name in sys.modules]
from tinyrace.config import load_env_config
from tinyrace.config.reference import markdown
from tinyrace.examples import TRACKS_DIR
from tinyrace.validate import validate_path
tmp, cases = Path(sys.argv[1]), json.loads(sys.argv[2])
results = []
for i, (track, sensor, model, driver) in enumerate(cases):
    env = {"sensors": [{"id": "s", "type": sensor}]}
    if model is not None:
        env["car"] = {"model": model}
    loaded = load_env_config(environment=track, overrides=env).config
    if track is not None:
        env["environment"] = str(TRACKS_DIR / track)
    experiment = tmp / f"case{i}.yaml"
    experiment.write_text(json.dumps({"env": env, "driver": driver}))  # JSON is YAML
    problems, summary = validate_path(experiment)
    mine = [entry.type for entry in loaded.sensors if entry.id == "s"]
    results.append({"kind": loaded.kind, "sensor": mine,
                    "model": loaded.car.model, "problems": problems, "summary": summary})
print(json.dumps({"imported": imported, "cases": results, "reference": markdown()}))
"""


@pytest.mark.slow  # nine envs built and stepped in a fresh interpreter
def test_every_built_in_part_is_known_to_each_layer_after_import_tinyrace_alone(
    tmp_path: Path,
) -> None:
    """``import tinyrace`` imports no registry (it stays light), yet a config that uses any
    built-in track type, sensor type, car model or driver loads through the config layer,
    passes ``tinyrace validate`` and is in the generated reference."""
    tinyrace.load_parts()
    from tinyrace.cars.registry import CAR_MODELS
    from tinyrace.drivers import DRIVERS
    from tinyrace.sensors.registry import SENSOR_TYPES
    from tinyrace.tracks.registry import TRACK_SOURCES

    used = {(c[1], c[2], c[3]) for c in BUILT_IN_CASES}
    assert {sensor for sensor, _, _ in used} == set(SENSOR_TYPES)
    assert {model for _, model, _ in used} - {None} == set(CAR_MODELS)
    assert {driver for _, _, driver in used} == set(DRIVERS)
    done = _run(BUILT_IN_SCRIPT, tmp_path, str(tmp_path), json.dumps(BUILT_IN_CASES))
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["imported"] == []
    cases = result["cases"]
    assert [case["problems"] for case in cases] == [[] for _ in BUILT_IN_CASES]
    assert {case["kind"] for case in cases} == set(TRACK_SOURCES)
    for (_, sensor, model, _), case in zip(BUILT_IN_CASES, cases, strict=True):
        assert case["sensor"] == [sensor]
        assert re.search(r"(observes: |; )s ", case["summary"]), case["summary"]  # it observes
        if model is not None:
            assert f"{model} car" in case["summary"]
    page = result["reference"]
    for name in TRACK_SOURCES:
        assert f"## `track: type {name}`" in page
    for name in SENSOR_TYPES:
        assert f"## `sensors[i]: type {name}`" in page
    for name in CAR_MODELS:
        assert f"| `{name}` |" in page


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


# A track type, a rule part, a sensor type and a car model, registered by the user's code
# (the toys of tests/test_toy_recipes.py and tests/test_toy_car_model.py) in a fresh
# interpreter: config loading, ``tinyrace validate`` and the reference before and after.
TOYS_SCRIPT = """
import json, sys
from pathlib import Path
import gymnasium as gym
import tinyrace, toy_recipes, toy_car
from tinyrace.config import load_env_config
from tinyrace.config.reference import markdown
from tinyrace.errors import ConfigError
from tinyrace.validate import validate_path
track, experiment = Path(sys.argv[1]), Path(sys.argv[2])

def loads():
    try:
        load_env_config(config=track)
    except ConfigError as exc:
        return [str(problem) for problem in exc.problems]
    return []

def known():
    page = markdown()
    return {"config": loads(), "validate": validate_path(track),
            "model": validate_path(experiment)[0],
            "page": [title in page for title in ("## `track: type ring`",
                     "## `sensors[i]: type compass`", "## `rules[i]: type speed_limit`",
                     "| `hopper` | centerline, cone_map, ring, ros_map | a toy unicycle |")]}

before = known()
from tinyrace.cars.registry import register as register_car
from tinyrace.episodes.rules import RulePart, register as register_rule
from tinyrace.sensors.base import SensorType
from tinyrace.sensors.registry import register as register_sensor
from tinyrace.tracks.registry import register as register_track
register_track(toy_recipes.RingTrackConfig, toy_recipes.RingSource)
register_rule(RulePart("finish_gate", toy_recipes.FinishGate))
register_rule(toy_recipes.SPEED_LIMIT)
register_sensor(SensorType("compass", toy_recipes.CompassConfig, toy_recipes.build_compass))
register_car(toy_car.HOPPER)
env = gym.make("tinyrace/TinyRace-v0", config=str(track))
env.reset(seed=0)
observation, *_ = env.step(env.action_space.sample())
print(json.dumps({"before": before, "after": known(), "compass": len(observation["c"])}))
"""


def test_parts_registered_by_user_code_are_known_to_config_validate_and_reference(
    tmp_path: Path,
) -> None:
    """Unknown before the user's code registers them (each named where it is used), then
    loaded, validated, stepped through ``gym.make`` and in the reference."""
    for toy, module in (("toy_recipes", "test_toy_recipes"), ("toy_car", "test_toy_car_model")):
        (tmp_path / f"{toy}.py").write_text((ROOT / "tests" / f"{module}.py").read_text())
    track = tmp_path / "track.yaml"
    track.write_text(
        "tracks: [{type: ring, radius: 30.0}]\n"
        "car: {model: hopper}\n"
        "sensors: [{id: c, type: compass}]\n"
        "rules: [{type: speed_limit, limit: 50.0}]\n"
    )
    experiment = tmp_path / "hopper.yaml"  # the toy car on a shipped track
    circuit = TRACKS_DIR / "circuit"
    experiment.write_text(f"env: {{environment: '{circuit}', car: {{model: hopper}}}}\n")
    done = _run(TOYS_SCRIPT, tmp_path, ROOT / "tests", str(track), str(experiment))
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    before, after = result["before"], result["after"]
    for key in ("tracks[0].type", "sensors[0].type", "rules[0].type"):
        assert any(key in line for line in before["config"]), before["config"]
        assert any(key in line for line in before["validate"][0]), before["validate"]
    assert any("car.model" in line and "hopper" in line for line in before["model"])
    assert before["page"] == [False, False, False, False]
    assert after["config"] == [] and after["validate"][0] == [] and after["model"] == []
    summary = after["validate"][1]
    assert summary.startswith("ring track") and "hopper car" in summary and "c 2 " in summary
    assert after["page"] == [True, True, True, True]
    assert result["compass"] == 2


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
        "after, summary = validate_path(Path(r'TRACK'))\n"
        "page = markdown()\n"
        "print(json.dumps({'before': before, 'after': after, 'summary': summary, 'page': "
        "'rules[i]: type speed_limit' in page and 'time over the limit that ends' in page}))\n"
    ).replace("TRACK", str(track))
    done = _run(script, tmp_path, ROOT / "tests")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert any("rules[0].type" in line for line in result["before"])
    assert result["after"] == [] and result["page"] is True
    assert re.search(r"rewards: [^;]*speeding; ends: [^;]*speeding", result["summary"])
