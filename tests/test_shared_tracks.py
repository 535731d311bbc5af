"""Envs of one fixed track share its read-only data (the loaded track, ground textures,
lidar tables), build pictures only when read, and still see exactly what envs made alone
see; per-episode data (CarRacing's random track, visited tiles) stays per env."""

from __future__ import annotations

import dataclasses
import gc
import os
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from tinyrace import cache
from tinyrace.examples import TRACKS_DIR

LIDAR = {"type": "lidar", "id": "lidar", "beams": 64, "hit_classes": True}
CONES = {"sensors": [{**LIDAR, "blocks": ["off_road", "cones"]}]}
ALONE = {"cache": {"max_size": 0}}  # built in memory, shared with nobody (after forget)


def make(environment: str, **kwargs: object) -> gym.Env:
    return gym.make("tinyrace/TinyRace-v0", environment=environment, **kwargs)


def arrays_in(value: object, seen: set[int] | None = None) -> list[np.ndarray]:
    """Every numpy array inside ``value`` (dataclasses, objects, containers)."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return []
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, (str, bytes, int, float, type(None))):
        return []
    if isinstance(value, (list, tuple)):
        items: list[object] = list(value)
    elif isinstance(value, dict):
        items = list(value.values())
    elif dataclasses.is_dataclass(value):
        items = [getattr(value, f.name) for f in dataclasses.fields(value)]
    elif hasattr(value, "__dict__"):
        items = [v for k, v in vars(value).items() if not k.startswith("_")]
    else:
        return []
    return [array for item in items for array in arrays_in(item, seen)]


def shared_parts(env: gym.Env) -> list[object]:
    """What an env on a fixed track shares with the others: track source, texture, lidar."""
    inner = env.unwrapped
    lidar = next(s for s in inner.sensors if s.id == "lidar")
    return [inner.track_source, inner.ground.texture(inner.layout), lidar.field, lidar.fan]


def test_envs_of_one_track_share_its_data_read_only():
    first = make("circuit", sensors=[LIDAR])
    second = make("circuit", sensors=[LIDAR])
    for env in (first, second):
        env.reset(seed=0)
    for mine, theirs in zip(shared_parts(first), shared_parts(second), strict=True):
        assert mine is theirs
    found = [a for part in shared_parts(first) for a in arrays_in(part)]
    assert len(found) > 10
    assert not [a.shape for a in found if a.flags.writeable]
    tiles = first.unwrapped.track_source.tracks[0].tiles
    with pytest.raises(ValueError, match="read-only"):
        tiles[0, 0, 0] = 1.0


def test_a_picture_nobody_reads_is_not_built():
    env = make("circuit", cameras=[], sensors=[LIDAR])
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    assert env.unwrapped.ground.textures == [None]
    camera = make("circuit")
    camera.reset(seed=0)
    assert camera.unwrapped.ground.textures[0] is not None  # its camera read it


def run(env: gym.Env, seed: int, actions: list[np.ndarray]) -> list[object]:
    """The observations of an episode's reset and steps."""
    seen = [env.reset(seed=seed)[0]]
    seen += [env.step(action)[0] for action in actions]
    return seen


def assert_same_observations(a: list[object], b: list[object]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if isinstance(x, dict):
            assert x.keys() == y.keys()  # type: ignore[union-attr]
            for key in x:
                assert_same_observations([x[key]], [y[key]])  # type: ignore[index]
        else:
            assert np.array_equal(x, y)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("environment", "kwargs"),
    [("autocross", CONES), ("carolo_cup", {}), ("carracing", {})],
)
def test_one_envs_episode_cannot_change_what_another_sees(environment: str, kwargs: dict):
    """Two envs stepped differently, together, see what each sees when made alone."""

    def fresh(extra: dict) -> gym.Env:
        if environment == "carracing":
            return gym.make("tinyrace/CarRacing-v0")
        return make(environment, **kwargs, **extra)

    rng = np.random.default_rng(0)
    probe = fresh({})
    plans = [[probe.action_space.sample() for _ in range(40)] for _ in range(2)]
    for plan in plans:  # full throttle ahead, different steering: different tiles, cones
        for action in plan:
            if action.shape == (3,):
                action[1:] = (1.0, 0.0)
            action[0] = rng.uniform(-1, 1)
    alone = []
    for seed, plan in zip((0, 1), plans, strict=True):
        cache.forget()
        alone.append(run(fresh(ALONE), seed, plan))
    cache.forget()
    a, b = fresh({}), fresh({})
    together: list[list[object]] = [[a.reset(seed=0)[0]], [b.reset(seed=1)[0]]]
    for step in range(40):
        together[0].append(a.step(plans[0][step])[0])
        together[1].append(b.step(plans[1][step])[0])
    for mine, reference in zip(together, alone, strict=True):
        assert_same_observations(mine, reference)


def test_per_episode_data_stays_with_its_env():
    a, b = gym.make("tinyrace/CarRacing-v0"), gym.make("tinyrace/CarRacing-v0")
    a.reset(seed=0)
    b.reset(seed=0)
    assert a.unwrapped.track_source is not b.unwrapped.track_source
    ground_a, ground_b = a.unwrapped.ground, b.unwrapped.ground
    assert ground_a.texture(a.unwrapped.layout) is not ground_b.texture(b.unwrapped.layout)
    assert a.unwrapped.layout is not b.unwrapped.layout


def test_another_file_is_another_track(tmp_path: Path):
    folder = tmp_path / "circuit"
    shutil.copytree(TRACKS_DIR / "circuit", folder)
    copy = make(str(folder))
    assert make(str(folder)).unwrapped.track_source is copy.unwrapped.track_source
    csv = folder / "circuit.csv"
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(lines[:-1]) + "\n")  # one point fewer, same file name
    changed = make(str(folder))
    assert changed.unwrapped.track_source is not copy.unwrapped.track_source
    lines_now = [e.unwrapped.track_source.tracks[0].centerline for e in (copy, changed)]
    assert lines_now[0].shape != lines_now[1].shape or not np.array_equal(*lines_now)


def test_nothing_is_written_into_the_track_folder(tmp_path: Path):
    folder = tmp_path / "circuit"
    shutil.copytree(TRACKS_DIR / "circuit", folder)
    before = sorted(p.name for p in folder.iterdir())
    env = make(str(folder), sensors=[LIDAR], render_mode="rgb_array", cache={"dir": None})
    env.reset(seed=0)
    env.render()
    assert sorted(p.name for p in folder.iterdir()) == before


def _memory() -> float:
    """[MB] RSS of this process."""
    with open(f"/proc/{os.getpid()}/smaps_rollup") as rollup:
        for line in rollup:
            if line.startswith("Rss:"):
                return int(line.split()[1]) / 1024
    raise AssertionError("no Rss line")


@pytest.mark.skipif(not Path("/proc/self/smaps_rollup").exists(), reason="Linux /proc only")
@pytest.mark.parametrize(
    "kwargs", [{}, {"cameras": [], "sensors": [LIDAR]}], ids=["camera", "lidar"]
)
def test_an_extra_env_on_the_circuit_costs_little_memory(kwargs: dict):
    held = [make("circuit", **kwargs)]
    held[0].reset(seed=0)
    gc.collect()
    before = _memory()
    for seed in range(1, 4):
        env = make("circuit", **kwargs)
        env.reset(seed=seed)
        for _ in range(5):
            env.step(env.action_space.sample())
        held.append(env)
    assert (_memory() - before) / 3 <= 20.0  # [MB] per env (unshared: about 170)


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="Linux /proc only")
def test_worker_processes_map_one_cache_file():
    """A vector env's workers share the circuit's texture and lidar tables: both map the
    same cache files, read-only."""
    import multiprocessing

    from tinyrace.vector import make_batch

    envs = make_batch("tinyrace/TinyRace-v0", 4, workers=2, environment="circuit", sensors=[LIDAR])
    try:
        envs.reset(seed=0)
        folder = str(cache.default_folder())
        mapped = []
        for worker in multiprocessing.active_children():
            with open(f"/proc/{worker.pid}/maps") as maps:
                lines = [line.split() for line in maps if folder in line and ".npc" in line]
            assert all(fields[1].startswith("r-") for fields in lines)  # read-only pages
            mapped.append({fields[-1] for fields in lines})
        assert len(mapped) == 2
        assert len(mapped[0]) >= 2 and mapped[0] == mapped[1]  # texture and lidar field
    finally:
        envs.close()
