"""Hostile input at the Python API's doors and a few commands (round 7, F15-F23).

CarRacing's true/false keywords; an empty ``config=``; the race env's unknown agents and a
step after the race; the RLlib adapters given the wrong kind of env; ``tinyrace cache`` on
a path that is no folder it can read; the ``*_list`` render modes of TinyRace-v0;
``tinyrace examples copy`` through a link or into the package; ``show --seed`` on a track
that has one picture; ``render_mode="human"`` with no display.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.errors import ConfigError

CARRACING = "tinyrace/CarRacing-v0"
TINYRACE = "tinyrace/TinyRace-v0"


# -- F15: CarRacing's flags are true or false -----------------------------------------------------
@pytest.mark.parametrize("key", ["continuous", "verbose", "domain_randomize"])
@pytest.mark.parametrize("value", ["no", "False", "yes", 2, -1, 0.0, None, [True]])
def test_a_carracing_flag_that_is_not_true_or_false_is_refused(key, value):
    with pytest.raises(ConfigError) as raised:
        gym.make(CARRACING, **{key: value})
    assert str(raised.value).splitlines()[-1].strip() == (
        f"<kwargs>: {key}: got {value!r}; expected true or false (or 0 or 1)"
    )


def test_tinyrace_verbose_is_true_or_false_too():
    with pytest.raises(
        ConfigError, match=r"<kwargs>: verbose: got 'loud'; expected true or false \(or 0 or 1\)"
    ):
        gym.make(TINYRACE, verbose="loud")


def test_carracing_continuous_takes_0_and_1_as_carracing_v3_does():
    assert gym.make(CARRACING, continuous=0).action_space == gym.spaces.Discrete(5)
    assert gym.make(CARRACING, continuous=np.int64(1)).action_space.shape == (3,)


@pytest.mark.parametrize("flag", [np.False_, False])
def test_carracing_flags_take_bools_and_numpy_bools(flag, capsys):
    on = np.logical_not(flag)  # a numpy bool, True
    env = gym.make(CARRACING, continuous=flag, domain_randomize=np.bool_(True), verbose=on)
    assert env.action_space == gym.spaces.Discrete(5)
    assert env.unwrapped.config.tracks[0].domain_randomize is True
    env.reset(seed=0)
    assert "Track generation" in capsys.readouterr().out  # verbose=True prints it
    assert isinstance(env.unwrapped.verbose, bool)
    env.close()


# -- F17: an empty config= names no file ----------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "key", "value"),
    [
        ({"config": ""}, "config", ""),
        ({"config": "  "}, "config", "  "),
        ({"config": "", "environment": "formula_student"}, "config", ""),
        ({"environment": ""}, "environment", ""),
    ],
)
def test_an_empty_config_or_environment_is_refused_as_a_keyword(kwargs, key, value):
    with pytest.raises(ConfigError) as raised:
        gym.make(TINYRACE, **kwargs)
    text = str(raised.value)
    assert f"<kwargs>: {key}: got {value!r}; expected a " in text
    assert "track.yaml: got" not in text  # not the working folder's track.yaml
    if key == "config":
        assert "a YAML file path, a track folder or a mapping" in text
    else:
        assert "formula_student" in text  # the shipped tracks it could name


# -- F18: the race env's unknown agents and a step after the race -------------------------------
@pytest.fixture
def race():
    from tinyrace.race import parallel_env

    env = parallel_env(environment="f1tenth_loop", num_agents=2)
    yield env
    env.close()


@pytest.mark.parametrize("space", ["observation_space", "action_space"])
@pytest.mark.parametrize("agent", ["car_9", 5, ["car_0"]])
def test_an_unknown_agent_is_a_key_error_that_lists_the_agents(race, space, agent):
    from tinyrace.race import UnknownAgent

    with pytest.raises(KeyError) as raised:
        getattr(race, space)(agent)
    assert isinstance(raised.value, UnknownAgent)
    assert str(raised.value) == f"no agent {agent!r}; the agents are car_0, car_1"


def test_the_same_space_object_for_a_known_agent(race):
    assert race.observation_space("car_1") is race.observation_space("car_1")
    assert race.action_space("car_0") is race.action_space("car_0")


def test_a_step_after_the_race_says_the_race_is_over(race):
    with pytest.raises(gym.error.ResetNeeded, match=r"^call reset\(\) before step\(\)$"):
        race.step({})
    race.reset(seed=0)
    for _ in range(20_000):
        if not race.agents:
            break
        race.step({agent: race.action_space(agent).sample() for agent in race.agents})
    assert race.agents == []
    zeros = {agent: np.zeros(2, np.float32) for agent in race.possible_agents}
    for actions in (zeros, {}):
        with pytest.raises(gym.error.ResetNeeded) as raised:
            race.step(actions)
        assert str(raised.value) == "the race is over (every car is done): call reset()"
    race.reset(seed=1)
    assert race.agents == ["car_0", "car_1"]  # and it races again
    race.step(zeros)


# -- F19: the RLlib adapters name the env they take -----------------------------------------------
def _envs():
    from tinyrace.race import parallel_env

    single = gym.make(CARRACING, max_episode_steps=5)
    vector = gym.make_vec(CARRACING, num_envs=2, vectorization_mode="vector_entry_point", workers=0)
    race = parallel_env(environment="f1tenth_loop", num_agents=2)
    return {"TimeLimit": single, "BatchVectorEnv": vector, "RaceEnv": race}


@pytest.mark.parametrize(
    ("wrapper", "takes", "expected"),
    [
        ("FloatPixels", "TimeLimit", "a Gymnasium env (gym.make(...))"),
        ("FloatPixelsVector", "BatchVectorEnv", "a Gymnasium vector env (gym.make_vec(...))"),
        ("FloatPixelsParallel", "RaceEnv", "a PettingZoo ParallelEnv (tinyrace.race.parallel_env)"),
    ],
)
def test_a_float_pixels_wrapper_given_another_kind_of_env_is_a_type_error(wrapper, takes, expected):
    import tinyrace.rllib as rllib

    envs = _envs()
    make = getattr(rllib, wrapper)
    advice = {"TimeLimit": "FloatPixels", "BatchVectorEnv": "FloatPixelsVector"}
    advice["RaceEnv"] = "FloatPixelsParallel"
    for given, env in envs.items():
        if given == takes:
            make(env)  # its own kind is taken
            continue
        with pytest.raises(TypeError) as raised:
            make(env)
        assert str(raised.value) == f"expected {expected}, got {given}: wrap it in {advice[given]}"
    for junk in (None, "tinyrace/CarRacing-v0"):
        with pytest.raises(TypeError) as raised:
            make(junk)
        assert str(raised.value) == f"expected {expected}, got {type(junk).__name__}"
    for env in envs.values():
        env.close()


@pytest.mark.parametrize(
    ("config", "said"),
    [
        (None, "<RLlib env_config>: got None; expected a dict"),
        ({}, '<RLlib env_config>: got {}; expected a dict with "num_envs"'),
        ({"num_envs": 2, "id": 5}, "<RLlib env_config>: id: got 5; expected an env id"),
    ],
)
def test_make_vector_env_checks_its_config_as_make_env_does(config, said):
    from tinyrace.rllib import make_vector_env

    with pytest.raises(ConfigError) as raised:
        make_vector_env(config)
    assert said in str(raised.value)


# -- F16: the *_list render modes on TinyRace-v0 as on CarRacing-v0 -----------------------------
@pytest.mark.parametrize(
    "kwargs",
    [
        {"id": CARRACING},
        {"id": TINYRACE},
        {"id": TINYRACE, "environment": "formula_student"},
        {"id": TINYRACE, "environment": "formula_student", "opponents": [{"driver": "centerline"}]},
    ],
    ids=["carracing", "tinyrace", "formula_student", "with_opponents"],
)
@pytest.mark.parametrize("mode", ["rgb_array", "state_pixels"])
def test_a_list_render_mode_collects_the_frames_since_the_last_render(kwargs, mode):
    kwargs = dict(kwargs)
    env = gym.make(kwargs.pop("id"), render_mode=f"{mode}_list", **kwargs)
    single = gym.make(env.spec.id, render_mode=mode, **kwargs)
    assert env.render_mode == f"{mode}_list"
    env.reset(seed=0)
    single.reset(seed=0)
    action = env.action_space.sample()
    env.step(action)
    single.step(action)
    frames = env.render()
    assert isinstance(frames, list) and len(frames) == 2  # the reset's and the step's
    assert np.array_equal(frames[-1], single.render())
    assert env.render() == []  # emptied by the last render()
    env.close()
    single.close()


def test_the_env_class_names_the_list_modes_gym_make_adds():
    from tinyrace.env import TinyRaceEnv

    with pytest.raises(ConfigError, match=r"render_mode: got 'rgb_array_list'; .*gym\.make also"):
        TinyRaceEnv(render_mode="rgb_array_list")


# -- F20: tinyrace cache on a path that is no folder it can read -----------------------------------
def _cache_cli(args, capsys):
    from tinyrace import cli

    code = cli.main(["cache", *args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def cache_env(monkeypatch, tmp_path):
    from tinyrace import cache

    for name in (cache.DIR_VARIABLE, "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("action", ["info", "clear"])
@pytest.mark.parametrize("variable", ["TINYRACE_CACHE_DIR", "XDG_CACHE_HOME", "--dir"])
@pytest.mark.parametrize("kind", ["file", "device"])
def test_a_cache_folder_that_is_a_file_or_device_is_refused(
    cache_env, monkeypatch, capsys, action, variable, kind
):
    path = cache_env / "precious"
    path.write_text("mine\n")
    named = "precious" if kind == "file" else "/dev/null"  # short: shown whole
    args = [action]
    if variable == "--dir":
        args += ["--dir", named]
    else:
        monkeypatch.setenv(variable, named)
    code, out, err = _cache_cli(args, capsys)
    assert code == 2 and out == ""
    source = "<command line>: --dir" if variable == "--dir" else f"<environment>: ${variable}"
    what = "a file" if kind == "file" else "a character device"
    assert err == (
        f"tinyrace: error: {source}: got {named!r}; expected a readable folder: "
        f"{named} is {what}, not a folder\n"
    )
    assert path.read_text() == "mine\n"  # the file is left as it was


@pytest.mark.parametrize("action", ["info", "clear"])
def test_a_cache_folder_that_cannot_be_read_is_refused(cache_env, monkeypatch, capsys, action):
    import os

    folder = cache_env / "c"
    folder.mkdir()
    real = os.scandir

    def refused(path="."):  # chmod 000 as a user sees it (root reads any folder)
        if os.fspath(path) == "c":
            raise PermissionError(13, "Permission denied", path)
        return real(path)

    monkeypatch.setattr(os, "scandir", refused)
    code, _, err = _cache_cli([action, "--dir", "c"], capsys)
    assert code == 2
    assert err == (
        "tinyrace: error: <command line>: --dir: got 'c'; expected a readable folder: "
        "c cannot be read (Permission denied)\n"
    )


def test_a_cache_folder_that_does_not_exist_yet_holds_nothing(cache_env, capsys):
    code, out, _ = _cache_cli(["info"], capsys)
    assert code == 0
    assert f"cache folder: {cache_env / 'home' / '.cache' / 'tinyrace'}\n0 file(s)" in out
    assert _cache_cli(["clear", "--dir", "new"], capsys)[:2] == (
        0,
        "removed 0 cache file(s) from new\n",
    )


def test_clear_says_which_cache_files_it_could_not_remove(cache_env, monkeypatch, capsys):
    from pathlib import Path

    from tinyrace.cache import disk

    folder = cache_env / "c"
    folder.mkdir()
    entries = [folder / f"{digit * 64}.npc" for digit in "01"]
    for entry in entries:
        entry.write_bytes(disk.MAGIC + b"an entry")
    real = Path.unlink

    def read_only(self, missing_ok=False):  # a read-only folder, as a user sees it
        if self.name == entries[0].name:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self, missing_ok)

    monkeypatch.setattr(Path, "unlink", read_only)
    code, out, err = _cache_cli(["clear", "--dir", "c"], capsys)
    assert code == 2 and out == ""
    assert err == (
        "tinyrace: error: <command line>: --dir: got 'c'; expected a folder whose files can be "
        "removed: 1 cache file(s) left in c (Permission denied; removed 1)\n"
    )
    assert entries[0].exists() and not entries[1].exists()


# -- F21: examples copy writes no link and nothing into the package -------------------------------
def test_copy_refuses_a_target_that_is_a_link_pointing_nowhere(tmp_path, capsys):
    from tinyrace import cli

    outside = tmp_path / "outside"
    outside.mkdir()
    here = tmp_path / "here"
    here.mkdir()
    (here / "carracing.yaml").symlink_to(outside / "nowhere.yaml")
    (here / "circuit").symlink_to(outside / "no_folder")
    for name in ("carracing", "circuit"):
        assert cli.main(["examples", "copy", name, str(here)]) == 2
        err = capsys.readouterr().err
        assert f"{here / name}" in err and "exists (a symbolic link); nothing is overwritten" in err
    assert list(outside.iterdir()) == []  # nothing written through the links


@pytest.mark.parametrize("where", ["package", "package_sub", "tracks", "configs"])
def test_copy_and_run_refuse_a_folder_inside_the_package(where, capsys):
    from tinyrace import cli
    from tinyrace.examples import CONFIGS_DIR, PACKAGE_DIR, TRACKS_DIR

    folder = {
        "package": PACKAGE_DIR,
        "package_sub": PACKAGE_DIR / "copies",
        "tracks": TRACKS_DIR,
        "configs": CONFIGS_DIR / "mine",
    }[where]
    before = sorted(p.name for p in folder.parent.iterdir())
    assert cli.main(["examples", "copy", "carracing", str(folder)]) == 2
    err = capsys.readouterr().err
    assert "a folder outside the installed package" in err and str(folder) in err
    assert cli.main(["run", "carracing", "-o", str(folder), "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "lies inside the installed package" in err and "--force" in err
    assert sorted(p.name for p in folder.parent.iterdir()) == before  # nothing made there


@pytest.fixture
def shipped(tmp_path, monkeypatch):
    """A copy of two shipped examples in a package of the test's own."""
    import shutil

    from tinyrace import examples

    package = tmp_path / "package"
    tracks, configs = package / "example_tracks", package / "configs"
    configs.mkdir(parents=True)
    shutil.copytree(examples.TRACKS_DIR / "circuit", tracks / "circuit")
    shutil.copyfile(examples.CONFIGS_DIR / "carracing.yaml", configs / "real.yaml")
    monkeypatch.setattr(examples, "PACKAGE_DIR", package)
    monkeypatch.setattr(examples, "TRACKS_DIR", tracks)
    monkeypatch.setattr(examples, "CONFIGS_DIR", configs)
    return package


def test_a_shipped_link_inside_is_copied_as_its_file_under_its_own_name(shipped, tmp_path):
    from tinyrace.examples import copy_example

    (shipped / "configs" / "carracing.yaml").symlink_to("real.yaml")
    target = tmp_path / "mine"
    assert copy_example("carracing", target) == [target / "carracing.yaml"]
    copied = target / "carracing.yaml"
    assert not copied.is_symlink()
    assert copied.read_bytes() == (shipped / "configs" / "real.yaml").read_bytes()
    assert sorted(p.name for p in target.iterdir()) == ["carracing.yaml"]


@pytest.mark.parametrize("link", ["config", "config_dangling", "track_file"])
def test_a_shipped_link_out_of_the_package_is_refused(shipped, tmp_path, link):
    from tinyrace.examples import copy_example

    secret = tmp_path / "secret.txt"
    secret.write_text("not the package's")
    name = "circuit" if link == "track_file" else "carracing"
    if link == "track_file":
        (shipped / "example_tracks" / "circuit" / "notes.txt").symlink_to(secret)
    else:
        points = secret if link == "config" else shipped.parent / "nowhere.yaml"
        (shipped / "configs" / "carracing.yaml").symlink_to(points)
    target = tmp_path / "mine"
    with pytest.raises(ConfigError, match="does not resolve inside it"):
        copy_example(name, target)
    assert not target.exists()  # nothing copied
    assert not (shipped.parent / "nowhere.yaml").exists()


# -- F22: show --seed on a track whose picture does not depend on it ----------------------------
def _shipped_tracks():
    from tinyrace.examples import track_names

    return track_names()


@pytest.mark.parametrize("name", [*_shipped_tracks(), "carracing", "procedural"])
def test_a_picture_says_whether_the_seed_chose_it(name):
    from tinyrace.examples import find_example
    from tinyrace.validate import picture

    target = name if name == "procedural" else str(find_example(name))
    first, other = picture(target, 0), picture(target, 3)
    assert first.seeded == other.seeded
    assert first.seeded is not np.array_equal(first.image, other.image)


@pytest.mark.parametrize(
    ("args", "noted"),
    [
        (["formula_student", "--seed", "3"], True),
        (["formula_student", "--seed", "0"], True),  # given: said, even for the default
        (["formula_student"], False),
        (["procedural", "--seed", "3"], False),
    ],
)
def test_show_notes_a_seed_that_changes_nothing(args, noted, tmp_path, capsys):
    from tinyrace import cli

    assert cli.main(["show", *args, "-o", str(tmp_path / "p.png")]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("wrote ")
    note = f"tinyrace: note: --seed {args[-1]} is ignored: only a procedural track's picture "
    assert err == (note + "depends on the seed\n" if noted else "")


# -- F23: render_mode="human" with no display -------------------------------------------------
@pytest.fixture
def headless(monkeypatch):
    """A Linux machine with no display and no SDL driver chosen."""
    import sys

    monkeypatch.setattr(sys, "platform", "linux")
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)


@pytest.mark.parametrize("kwargs", [{"id": CARRACING}, {"id": TINYRACE, "environment": "circuit"}])
def test_a_human_window_with_no_display_is_a_clear_error(headless, kwargs):
    from tinyrace.render.window import NoDisplay

    kwargs = dict(kwargs)
    env = gym.make(kwargs.pop("id"), render_mode="human", **kwargs)
    with pytest.raises(NoDisplay) as raised:
        env.reset(seed=0)
    assert str(raised.value).startswith(
        'render_mode="human" needs a display: no DISPLAY or WAYLAND_DISPLAY is set'
    )
    assert "SDL_VIDEODRIVER=dummy" in str(raised.value)
    env.close()


def test_an_sdl_driver_that_does_not_exist_is_a_clear_error(headless, monkeypatch):
    """pygame's own error (``bogus not available``) came as a traceback from inside it."""
    from tinyrace.render.window import NoDisplay

    monkeypatch.setenv("SDL_VIDEODRIVER", "bogus")
    env = gym.make(CARRACING, render_mode="human")
    with pytest.raises(NoDisplay) as raised:
        env.reset(seed=0)
    text = str(raised.value)
    assert text.startswith('render_mode="human" cannot open a window (SDL_VIDEODRIVER=bogus): ')
    assert "SDL_VIDEODRIVER=dummy" in text
    env.close()


@pytest.mark.parametrize(
    "environ",
    [{"SDL_VIDEODRIVER": "dummy"}, {"SDL_VIDEODRIVER": "offscreen"}, {"DISPLAY": ":0"}],
)
def test_a_display_or_a_chosen_sdl_driver_is_no_error(headless, monkeypatch, environ):
    from tinyrace.render.window import display_missing

    for name, value in environ.items():
        monkeypatch.setenv(name, value)
    assert display_missing() is None


def test_the_dummy_driver_still_renders_human_mode(headless, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    env = gym.make(CARRACING, render_mode="human")
    env.reset(seed=0)
    assert env.unwrapped._window.screen.get_size() == (1000, 800)
    assert env.render() is None
    env.close()
