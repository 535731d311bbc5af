"""A car knob that the car's model does not read is refused, never silently ignored; a
model chosen over a track's file drops the file's knobs of its own car (another car)."""

from __future__ import annotations

import dataclasses
import textwrap
from collections.abc import Iterator

import gymnasium as gym
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars.registry import CAR_MODELS, register, unregister
from tinyrace.config import car_models
from tinyrace.config.checks import CAR_KNOB_DEFAULTS
from tinyrace.config.load import load_env_config
from tinyrace.errors import ConfigError
from tinyrace.examples import find_track

ID = "tinyrace/TinyRace-v0"


def problems(**kwargs: object) -> list[tuple[str, str, object, str]]:
    with pytest.raises(ConfigError) as caught:
        gym.make(ID, **kwargs)
    return [(p.source, p.path, p.value, p.allowed) for p in caught.value.problems]


def test_every_built_in_model_says_which_knobs_it_reads():
    for name, model in CAR_MODELS.items():
        assert model.reads is not None, name
        assert model.reads <= set(CAR_KNOB_DEFAULTS), (name, model.reads - set(CAR_KNOB_DEFAULTS))
        assert car_models.car_models()[name].reads == model.reads
    # every knob is read by some model: a knob no model reads would always be refused
    read = set().union(*(m.reads or () for m in CAR_MODELS.values()))
    assert read == set(CAR_KNOB_DEFAULTS)


def test_a_single_track_car_refuses_the_kinematic_cars_sizes():
    found = problems(
        environment="circuit",
        car={"model": "single_track", "wheelbase": 0.5, "track_width": 0.5, "velocity": 2.0},
    )
    assert [(path, value) for _, path, value, _ in found] == [
        ("car.wheelbase", 0.5),
        ("car.track_width", 0.5),
        ("car.velocity", 2.0),
    ]
    source, _, _, allowed = found[0]
    assert source == "<kwargs>"
    assert "no car of this env reads car.wheelbase" in allowed
    assert "'single_track' reads compat, kinematic_below, preset, substeps" in allowed


def test_a_kinematic_car_refuses_a_preset_and_the_dynamic_car_a_top_speed():
    ((_, path, value, allowed),) = problems(
        environment="circuit", car={"model": "kinematic_throttle", "preset": "vehicle3"}
    )
    assert (path, value) == ("car.preset", "vehicle3")
    assert "'kinematic_throttle' reads max_acceleration" in allowed
    ((_, path, value, allowed),) = problems(car={"model": "dynamic", "velocity": 30.0})
    assert (path, value) == ("car.velocity", 30.0)
    assert "'dynamic' reads pixels_per_unit" in allowed


def test_a_knob_at_its_default_or_read_by_the_model_passes():
    env = gym.make(ID, environment="circuit", car={"model": "single_track", "preset": "f1tenth"})
    assert env.unwrapped.config.car.model == "single_track"
    env.close()
    env = gym.make(ID, environment="circuit", car={"max_steering_angle": 33.0, "velocity": 12.0})
    assert env.unwrapped.config.car.velocity == 12.0
    env.close()


def test_another_model_over_a_track_file_leaves_the_files_car_knobs_behind():
    """f1tenth_loop's file sizes a kinematic_throttle car (wheelbase, velocity, accelerations):
    choosing single_track over it is another car, not that one with knobs it cannot read."""
    loaded = load_env_config(
        environment="f1tenth_loop", overrides={"car": {"model": "single_track"}}
    )
    assert loaded.config.car.model == "single_track"
    # the same model over the file keeps the file's knobs under the overrides'
    kept = load_env_config(environment="f1tenth_loop", overrides={"car": {"velocity": 3.0}})
    file_only = load_env_config(environment="f1tenth_loop")
    assert kept.config.car.velocity == 3.0 != file_only.config.car.velocity
    assert kept.config.car.wheelbase == file_only.config.car.wheelbase
    assert kept.config.car.max_acceleration == file_only.config.car.max_acceleration != 6.0
    # a knob the new model does not read, given with it, is still refused
    ((_, path, _, _),) = problems(
        environment="f1tenth_loop", car={"model": "single_track", "max_acceleration": 2.0}
    )
    assert path == "car.max_acceleration"


def test_a_race_entry_is_held_to_its_own_model_and_a_shared_knob_to_some_car(tmp_path):
    circuit = find_track("circuit")
    assert circuit is not None
    text = textwrap.dedent(
        f"""\
        track: {{type: centerline, file: {circuit / "circuit.csv"}}}
        files: {{paths_outside_folder: true}}
        car: {{model: kinematic_throttle, velocity: 15.0}}
        race:
          cars:
            - id: ego
            - id: f1tenth
              car: {{model: single_track%s}}
        """
    )
    path = tmp_path / "race.yaml"
    # a shared knob that one car's model reads passes, inherited by one that does not
    path.write_text(text % "")
    loaded = load_env_config(path)
    assert [c.car.model for c in loaded.config.race.cars] == ["kinematic_throttle", "single_track"]
    # the entry's own unread knob is named at the entry, in the file
    path.write_text(text % ", velocity: 2.0")
    with pytest.raises(ConfigError) as caught:
        load_env_config(path)
    ((source, key, value, allowed),) = [
        (p.source, p.path, p.value, p.allowed) for p in caught.value.problems
    ]
    assert (key, value) == ("race.cars[1].car.velocity", 2.0)
    assert source.endswith("race.yaml") and "'single_track' reads" in allowed


@pytest.fixture
def anything_goes() -> Iterator[str]:
    """A registered model that does not say what it reads (a user's or a plugin's)."""
    model = CAR_MODELS["kinematic_throttle"]
    register(dataclasses.replace(model, name="plugin_car", default_for=frozenset(), reads=None))
    yield "plugin_car"
    unregister("plugin_car")


def test_a_model_that_does_not_say_what_it_reads_takes_every_knob(anything_goes):
    env = gym.make(ID, environment="circuit", car={"model": anything_goes, "preset": "vehicle3"})
    assert env.unwrapped.config.car.model == anything_goes
    env.close()


def test_a_race_of_other_models_over_a_track_file_leaves_the_files_car_knobs_behind():
    """Every car of the race a model of its own over circuit's kinematic car: none reads the
    file's wheelbase, so the file's knobs are another car's, not refused in the file."""
    both = {"cars": [{"car": {"model": "single_track"}}, {"car": {"model": "dynamic"}}]}
    loaded = load_env_config(environment="circuit", overrides={"race": both})
    assert [c.car.model for c in loaded.config.race.cars] == ["single_track", "dynamic"]
    # a car that keeps the file's model keeps the file's knobs
    one = {"cars": [{"car": {"model": "single_track"}}, {}]}
    kept = load_env_config(environment="circuit", overrides={"race": one})
    file_only = load_env_config(environment="circuit")
    assert kept.config.race.cars[1].car.max_acceleration == file_only.config.car.max_acceleration


def test_a_race_entrys_own_knob_is_refused_even_at_the_shared_value(tmp_path):
    circuit = find_track("circuit")
    assert circuit is not None
    path = tmp_path / "race.yaml"
    path.write_text(
        f"track: {{type: centerline, file: {circuit / 'circuit.csv'}}}\n"
        "files: {paths_outside_folder: true}\n"
        "car: {model: kinematic_throttle, velocity: 15.0}\n"
        "race: {cars: [{id: ego}, {id: st, car: {model: single_track, velocity: 15.0}}]}\n"
    )
    with pytest.raises(ConfigError) as caught:
        load_env_config(path)
    ((key, value),) = [(p.path, p.value) for p in caught.value.problems]
    assert (key, value) == ("race.cars[1].car.velocity", 15.0)
