"""Issue 39: each example of the fourth round of hostile input, pinned as a plain test.

Races, the PettingZoo env, opponents, calibrated cameras, the track cache and the commands
that write. Every case ends in a clear error (naming the car, file, key and value) or a
working env; no user file changes. The generated campaign over the same surface is
tests/test_hostile_round4_campaign.py.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml
from gymnasium.error import InvalidAction
from hypothesis import given
from hypothesis import strategies as st

from tinyrace import cache, cli
from tinyrace.cache import disk
from tinyrace.cache.codec import DataclassCodec
from tinyrace.config.bounds import MAX_CAMERA_PIXELS, MAX_ID_LENGTH, MAX_TRAIN_ENVS
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError
from tinyrace.experiment.race_runner import file_part
from tinyrace.race import aec_env, parallel_env
from tinyrace.race.opponents import make_env


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@contextlib.contextmanager
def alarm(seconds: int = 20):
    """Fail instead of hanging: SIGALRM after ``seconds``."""

    def hung(signum, frame):
        raise TimeoutError(f"hung for {seconds} s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


# -- the cache: what it may read, lock and remove -----------------------------------------------
@dataclass
class Table:
    values: np.ndarray
    scale: float


CODEC = DataclassCodec(Table)
BIG = 300_000  # float64 values: 2.4 MB, past cache.MIN_DISK_BYTES


def build_table() -> Table:
    return Table(np.arange(BIG, dtype=np.float64), 2.0)


def settings(folder: Path) -> cache.Settings:
    return cache.Settings(folder)


def stored_entry(folder: Path, key: str = "t") -> Path:
    cache.forget()
    cache.shared(key, build_table, settings(folder), CODEC)
    cache.forget()
    (path,) = disk.entries(folder)
    return path


def test_cache_clear_removes_only_what_the_cache_wrote(tmp_path: Path, capsys):
    folder = tmp_path / "mine"
    entry = stored_entry(folder)
    outside = tmp_path / "outside.bin"
    outside.write_bytes(b"keep")
    users = {
        "package.lock": b"lock of my project",
        "weights.npc": b"my weights",
        "a" * 64 + ".npc": b"not the cache's: no magic",
        "b" * 64 + ".lock": b"a lock of my own, with words",
        ".tmp-abcdefgh.npc": b"mine too",
    }
    for name, data in users.items():
        (folder / name).write_bytes(data)
    (folder / ("c" * 64 + ".npc")).symlink_to(outside)
    os.mkfifo(folder / ("d" * 64 + ".npc"))
    assert cli.main(["cache", "clear", "--dir", str(folder)]) == 0
    assert "removed 1 cache file(s)" in capsys.readouterr().out
    assert not entry.exists()
    for name, data in users.items():
        assert (folder / name).read_bytes() == data
    assert (folder / ("c" * 64 + ".npc")).is_symlink() and outside.read_bytes() == b"keep"
    assert (folder / ("d" * 64 + ".npc")).exists()


def test_trimming_the_cache_removes_only_its_own_entries_and_locks(tmp_path: Path):
    entry = stored_entry(tmp_path)
    user_entry = tmp_path / ("e" * 64 + ".npc")
    user_entry.write_bytes(b"x" * 5_000_000)  # large, old, named like an entry: not the cache's
    os.utime(user_entry, (0, 0))
    user_lock = entry.with_suffix(disk.LOCK_SUFFIX)
    user_lock.write_text("my own lock notes")
    disk.trim(tmp_path, 0)
    assert not entry.exists()
    assert user_entry.stat().st_size == 5_000_000
    assert user_lock.read_text() == "my own lock notes"


def test_cache_entries_replaced_by_fifos_are_neither_read_nor_removed(tmp_path: Path):
    entry = stored_entry(tmp_path)
    entry.unlink()
    os.mkfifo(entry)
    with alarm(), pytest.warns(RuntimeWarning, match="cannot use the cache folder"):
        table = cache.shared("t", build_table, settings(tmp_path), CODEC)
    assert table.values[-1] == BIG - 1
    assert entry.exists() and not entry.is_file()  # left where it was
    cache.forget()


def test_a_lock_file_that_is_a_fifo_does_not_block(tmp_path: Path):
    stored_entry(tmp_path, "other")  # the folder and its key exist
    name = cache.digest((cache.VERSION, "t"))
    os.mkfifo(tmp_path / f"{name}{disk.LOCK_SUFFIX}")
    with alarm(), pytest.warns(RuntimeWarning, match="not a regular file"):
        table = cache.shared("t", build_table, settings(tmp_path), CODEC)
    assert table.scale == 2.0
    cache.forget()


HOLDER = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT, 0o644)
fcntl.flock(fd, fcntl.LOCK_EX)
os.write(fd, f"{os.getpid()}\\n".encode())
print("held", flush=True)
time.sleep(120)
"""


def test_a_lock_held_past_the_bound_builds_privately_naming_the_holder(tmp_path, monkeypatch):
    stored_entry(tmp_path, "other")
    name = cache.digest((cache.VERSION, "t"))
    lock = tmp_path / f"{name}{disk.LOCK_SUFFIX}"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(lock)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        monkeypatch.setattr(disk, "LOCK_WAIT", 0.3)
        with alarm(), pytest.warns(RuntimeWarning, match=f"held by process {holder.pid}"):
            table = cache.shared("t", build_table, settings(tmp_path), CODEC)
        assert table.values[10] == 10.0
        assert not disk.path_of(tmp_path, name).exists()  # built in memory only
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
        cache.forget()


def _unkeyed(path: Path, edit) -> None:
    """Rewrite an entry's meta with ``edit`` and its checksum as sha256 (no key), its header
    otherwise as written: well-formed, but not made by the cache."""
    import json

    data = bytearray(path.read_bytes())
    fields = list(disk._HEADER.unpack_from(data, 0))
    meta_length = fields[8]
    meta = json.loads(bytes(data[disk.HEADER : disk.HEADER + meta_length]))
    edit(meta)
    text = json.dumps(meta).encode().ljust(meta_length)[:meta_length]
    data[disk.HEADER : disk.HEADER + meta_length] = text
    fields[7] = hashlib.sha256(bytes(data[disk.HEADER :])).digest()
    data[: disk.HEADER] = disk._HEADER.pack(*fields)
    path.write_bytes(bytes(data))


def _rename(meta) -> None:
    meta["arrays"][0][0] = "renamed"


def _truncate(meta) -> None:
    meta["arrays"][0][2] = [10]


@pytest.mark.parametrize("edit", [_rename, _truncate], ids=["renamed", "truncated"])
def test_an_entry_with_good_headers_but_other_arrays_is_rebuilt(tmp_path: Path, edit):
    entry = stored_entry(tmp_path)
    _unkeyed(entry, edit)
    table = cache.shared("t", build_table, settings(tmp_path), CODEC)
    assert table.values.shape == (BIG,)
    cache.forget()


def test_an_entry_signed_by_the_folder_key_but_not_decodable_builds_privately(tmp_path):
    stored_entry(tmp_path)
    name = cache.digest((cache.VERSION, "t"))
    wrong = disk.Entry({"values": {"array": "gone"}, "scale": 2.0}, {"other": np.zeros(BIG)})
    disk.write(tmp_path, name, cache.VERSION, wrong)
    with pytest.warns(RuntimeWarning, match="does not decode"):
        table = cache.shared("t", build_table, settings(tmp_path), CODEC)
    assert table.values[5] == 5.0
    cache.forget()


@pytest.mark.parametrize("folder", ["~nosuchuser-tinyrace/cache", "cache\x00dir"])
@pytest.mark.parametrize("action", ["info", "clear"])
def test_a_cache_folder_of_an_unknown_user_or_with_a_nul_byte(folder, action, capsys):
    assert cli.main(["cache", action, "--dir", folder]) == 2
    err = capsys.readouterr().err
    assert "--dir" in err and "internal error" not in err
    assert ("no user" in err) if "~" in folder else ("NUL" in err)


@pytest.mark.parametrize("folder", ["~nosuchuser-tinyrace/cache", "cache\x00dir"])
def test_a_config_or_variable_naming_such_a_cache_folder(folder, monkeypatch):
    with pytest.raises(ConfigError, match=r"cache\.dir"):
        TinyRaceEnv(cache={"dir": folder})
    if "\x00" not in folder:  # (no environment variable can hold a NUL byte)
        monkeypatch.setenv(cache.DIR_VARIABLE, folder)
        with pytest.raises(ConfigError, match=r"TINYRACE_CACHE_DIR"):
            cache.default_folder()


# -- the PettingZoo env's doors ------------------------------------------------------------------
RACE = {  # procedural: the dynamic car, whose actions are pedals or CarRacing's five
    "race": {"cars": [{"id": "pedals"}, {"id": "buttons", "car": {"actions": "discrete"}}]},
    "cameras": [],
    "sensors": [{"id": "state", "type": "state"}],
}


@pytest.fixture(scope="module")
def race():
    env = parallel_env(**RACE)
    yield env
    env.close()


@pytest.mark.parametrize("options", ["x", ["poses"], 3, 1.5, b"x"], ids=repr)
def test_reset_options_that_are_no_mapping_are_a_config_error(race, options):
    with pytest.raises(ConfigError, match="expected a dict of reset options"):
        race.reset(seed=0, options=options)
    aec = aec_env(**RACE)
    with pytest.raises(ConfigError, match="expected a dict of reset options"):
        aec.reset(seed=0, options=options)


NAN = float("nan")
BAD_BOX = [  # the pedals car: Box(3,) float32
    np.array([NAN, 0, 0], np.float32),
    np.array([0, np.inf, 0], np.float32),
    np.array([0, 0, -np.inf], np.float32),
    np.array([0.0, 0.5], np.float32),
    np.zeros(4, np.float32),
    np.zeros((3, 1), np.float32),
    np.zeros((), np.float32),
    np.array(["a", "b", "c"]),
    np.array([0, 0, 0], object),
    np.array([1 + 1j, 0, 0]),
    None,
    {"steer": 0.0},
    "left",
    [0.0, "x", 0.0],
    [[0.0, 0.0, 0.0]],
    [2.0, 0.0, 0.0],
]
BAD_DISCRETE = [5, -1, 1.5, None, True, np.array([1, 2])]  # the buttons car: Discrete(5)


def _cases():
    for i, action in enumerate(BAD_BOX):
        yield pytest.param("pedals", action, id=f"pedals-{i}")
    for i, action in enumerate(BAD_DISCRETE):
        yield pytest.param("buttons", action, id=f"buttons-{i}")


@pytest.mark.parametrize(("car", "action"), list(_cases()))
def test_a_bad_action_for_one_car_names_that_car_on_both_forms(race, car, action):
    race.reset(seed=0)
    actions = {"pedals": np.zeros(3, np.float32), "buttons": 0, car: action}
    before = race.state().copy()
    with pytest.raises(InvalidAction, match=f"car '{car}'"):
        race.step(actions)
    assert (race.state() == before).all()  # nothing moved
    aec = aec_env(**RACE)
    aec.reset(seed=0)
    with pytest.raises(InvalidAction, match=f"car '{car}'"):
        for agent in aec.agent_iter(2):
            aec.step(actions[agent])
    aec.close()


def test_reset_poses_of_true_and_false_are_refused_as_the_config_refuses_them(race):
    for poses in ([True, False, True], [[True, False, True], [0.0, 1.0, 0.0]]):
        with pytest.raises(ConfigError, match=r"poses: .*finite.*of numbers"):
            race.reset(seed=0, options={"poses": poses})
    with pytest.raises(ConfigError, match=r"race\.poses"):
        TinyRaceEnv(environment="circuit", race={"start": "poses", "poses": [[True, False, True]]})


def test_a_grid_longer_than_the_track_is_refused_at_race_grid_spacing():
    with pytest.raises(ConfigError, match=r"race\.grid_spacing: got 1000000000.0.*long"):
        parallel_env(environment="circuit", num_agents=3, race={"grid_spacing": 1e9})
    with pytest.raises(ConfigError, match=r"race\.grid_spacing: got 1000000000.0.*long"):
        make_env(environment="circuit", race={"grid_spacing": 1e9}, opponents=[{}, {}])


# -- opponents -----------------------------------------------------------------------------------
class Returns:
    def __init__(self, value):
        self.value = value

    def controls(self, pose, speed):
        return self.value


@pytest.mark.parametrize(
    "value",
    [0.5, "abc", None, ("a", "b", "c"), (1.0, 2.0), (NAN, 0.0, 0.0), (0.0, math.inf, 0.0),
     (True, 0.0, 0.0), {"steer": 0}, np.zeros((3, 1))],
    ids=repr,
)  # fmt: skip
def test_an_opponent_whose_controls_are_not_three_numbers_is_named(value):
    env = make_env(environment="circuit", opponents=[{"driver": Returns(value)}])
    env.reset(seed=0)
    with pytest.raises(ConfigError, match=r"(?s)opponents\[0\]\.driver\.controls.*car 'car_1'"):
        env.step(env.action_space.sample())
    env.close()


class RacingPageDriver:
    """docs/racing.md's own example: follow(route, action_space, dt), three arguments."""

    def __init__(self):
        self.followed = 0

    def follow(self, route, action_space, dt):
        self.followed += 1

    def controls(self, pose, speed):
        return (0.0, 0.3, 0.0)


class NoArgumentFollow(RacingPageDriver):
    def follow(self):  # type: ignore[override]
        pass


def test_the_racing_pages_driver_example_runs():
    driver = RacingPageDriver()
    page = (Path(__file__).parents[1] / "docs" / "racing.md").read_text()
    assert "follow(route, action_space, dt)" in page  # the signature the page shows
    env = make_env(environment="circuit", opponents=[{"driver": driver}])
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert driver.followed == 1
    env.close()
    env = make_env(environment="circuit", opponents=[{"driver": NoArgumentFollow()}])
    with pytest.raises(ConfigError, match=r"opponents\[0\]\.driver\.follow"):
        env.reset(seed=0)
    env.close()


# -- cameras -------------------------------------------------------------------------------------
def _perspective(**knobs):
    return {"type": "perspective_camera", "id": "p", "resolution": [8, 12], **knobs}


def test_a_camera_info_fifo_is_refused_without_blocking(tmp_path: Path):
    os.mkfifo(tmp_path / "camera.yaml")
    config = {"sensors": [_perspective(camera_info="camera.yaml")], "cameras": []}
    (tmp_path / "env.yaml").write_text(yaml.safe_dump(config))
    with alarm(), pytest.raises(ConfigError, match=r"camera_info.*regular file.*FIFO"):
        TinyRaceEnv(config=str(tmp_path / "env.yaml"))


def test_intrinsics_with_a_focal_length_of_1e12_px_work():
    env = TinyRaceEnv(sensors=[_perspective(intrinsics=[1e12, 1e12, 5.5, 3.5])])
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    observation, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(observation)
    env.close()


def test_intrinsics_nan_and_three_numbers_have_their_own_messages():
    messages = []
    for intrinsics in ([NAN, 1.0, 5.0, 3.0], [1.0, 1.0, 5.0]):
        with pytest.raises(ConfigError) as error:
            TinyRaceEnv(sensors=[_perspective(intrinsics=intrinsics)])
        messages.append(str(error.value))
    assert "intrinsics[0]: got nan; expected a number" in messages[0]
    assert "intrinsics: got [1.0, 1.0, 5.0]; expected a list of 4" in messages[1]
    assert "expected tuple" not in " ".join(messages)


def test_cameras_pixels_are_capped_per_env_not_per_car():
    side = 1024  # one car's perspective camera: 4 x 1 Mpx, well within the cap alone
    assert 4 * side * side <= MAX_CAMERA_PIXELS < 16 * 4 * side * side
    sensors = [_perspective(resolution=[side, side])]
    with pytest.raises(ConfigError, match=r"race\.num_agents: got '16 cars'.*of one env"):
        parallel_env(environment="circuit", num_agents=16, cameras=[], sensors=sensors)
    parallel_env(environment="circuit", num_agents=2, cameras=[], sensors=sensors).close()


# -- ids, file names and the commands that write -------------------------------------------------
@given(st.lists(st.text(min_size=1, max_size=80), min_size=2, max_size=5, unique=True))
def test_distinct_car_ids_never_share_a_file_name(ids):
    parts = [file_part(i) for i in ids]
    assert len({p.lower() for p in parts}) == len(ids)  # one to one, even ignoring case
    assert all(p and "/" not in p and "\x00" not in p and len(p) <= 40 for p in parts)


def test_ids_that_differ_past_64_characters_or_by_slash_and_question_mark():
    assert file_part("x/y") != file_part("x?y")
    long = "a" * 70
    assert file_part(long + "1") != file_part(long + "2")
    cars = [{"id": "a" * (MAX_ID_LENGTH + 1)}, {"id": "car"}]
    with pytest.raises(ConfigError, match=rf"race\.cars\[0\]\.id.*at most {MAX_ID_LENGTH}"):
        TinyRaceEnv(environment="circuit", race={"cars": cars})


RACE_RUN = {
    "env": {
        "environment": "circuit",
        "race": {"cars": [{"id": "écurie"}, {"id": "a,b"}, {"id": "x/y"}, {"id": "x?y"}]},
        "cameras": [],
        "sensors": [{"id": "state", "type": "state"}],
        "sim": {"step_limit": 15},
    },
    "driver": "centerline",
    "episodes": 1,
    "output": {"dir": "runs", "video": False},
}


@pytest.fixture(scope="module")
def race_run(tmp_path_factory) -> Path:
    here = tmp_path_factory.mktemp("race_run")
    (here / "r.yaml").write_text(yaml.safe_dump(RACE_RUN, allow_unicode=True))
    assert cli.main(["run", str(here / "r.yaml"), "--quiet", "-o", str(here / "runs")]) == 0
    (run_dir,) = (here / "runs").iterdir()
    return run_dir


def test_race_ids_like_ecurie_and_a_comma_b_run_and_report(race_run: Path, capsys):
    traces = sorted(p.name for p in race_run.glob("*_trace.csv"))
    assert len(traces) == 4  # x/y and x?y each their own
    assert cli.main(["report", str(race_run)]) == 0
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["report.html", "report_paths_000.png"])
def test_report_never_writes_through_a_symlink(race_run: Path, tmp_path: Path, name, capsys):
    target = tmp_path / "precious.txt"
    target.write_text("mine")
    (race_run / name).unlink()
    (race_run / name).symlink_to(target)
    try:
        assert cli.main(["report", str(race_run)]) == 2
        assert "not a symbolic link" in capsys.readouterr().err
        assert target.read_text() == "mine"
    finally:
        (race_run / name).unlink()
    assert cli.main(["report", str(race_run)]) == 0  # the run folder still reports


@pytest.mark.parametrize("kind", ["symlink", "fifo", "folder", "hardlink"])
def test_run_files_are_never_written_through_what_stands_at_their_name(tmp_path, kind):
    from tinyrace.experiment.files import write_text

    precious = tmp_path / "precious.txt"
    precious.write_text("mine")
    target = tmp_path / "run" / "episode_000_car_0_trace.csv"
    target.parent.mkdir()
    if kind == "symlink":
        target.symlink_to(precious)
    elif kind == "fifo":
        os.mkfifo(target)
    elif kind == "folder":
        target.mkdir()
    else:
        os.link(precious, target)
    with alarm():
        if kind == "hardlink":  # a regular file: replaced by a new one, the other name kept
            write_text(target, "t,x\n")
            assert target.read_text() == "t,x\n"
        else:
            with pytest.raises(
                ConfigError, match=f"not a {'symbolic link' if kind == 'symlink' else ''}"
            ):
                write_text(target, "t,x\n")
    assert precious.read_text() == "mine"
    assert sorted(p.name for p in target.parent.iterdir()) == [target.name]  # no temp left


def test_run_an_empty_name_is_an_error(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", ""]) == 2
    assert "NAME_OR_PATH: got ''" in (err := capsys.readouterr().err) and "empty name" in err
    assert not (tmp_path / "runs").exists()


def test_run_an_empty_name_yaml_here_is_an_error(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "circuit.yaml").write_text("")  # a shipped name: never run in its stead
    assert cli.main(["run", "circuit"]) == 2
    assert "circuit.yaml" in (err := capsys.readouterr().err) and "empty" in err
    assert not (tmp_path / "runs").exists()


def test_train_out_empty_is_refused_before_training(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["train", "--out", ""]) == 2
    assert "--out: got ''; expected a file name ending in .zip" in capsys.readouterr().err


def test_train_a_race_says_a_race_cannot_be_trained_this_way(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["train", "circuit_race"]) == 2
    err = capsys.readouterr().err
    assert "race of 4 cars cannot be trained this way" in err and "opponents" in err


def test_train_envs_past_the_bound_is_refused(capsys):
    assert cli.main(["train", "--envs", "100000"]) == 2
    assert f"from 1 to {MAX_TRAIN_ENVS}" in capsys.readouterr().err


def test_the_reference_lists_the_bounds_of_this_round():
    page = (Path(__file__).parents[1] / "docs" / "reference.md").read_text()
    for name in ("MAX_CAMERA_PIXELS", "MAX_TRAIN_ENVS", "MAX_ID_LENGTH", "MAX_LOCK_WAIT"):
        assert f"`{name}`" in page


def test_a_plain_car_id_is_its_own_file_name():
    assert [file_part(i) for i in ("car_0", "a.b-c", "x" * 40)] == ["car_0", "a.b-c", "x" * 40]
    assert file_part("Car_0") != "Car_0"  # capitals: a case-blind file system would merge them
