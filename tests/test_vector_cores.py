"""BatchVectorEnv(cores=...): worker processes pinned to cores, the same results, clear errors.

Each worker runs on the one core it was given (read back from the OS with
``os.sched_getaffinity`` of its pid), the steps equal an unpinned vector env's bit for bit,
and values that are no list of this process's cores (or ``workers=0``, which has no
process to pin, or a platform without ``sched_setaffinity``) raise a ConfigError naming
``cores``, the value and what is allowed.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from test_batch_vector import assert_same

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.errors import ConfigError
from tinyrace.vector import make_batch

PINNING = hasattr(os, "sched_setaffinity")  # Linux; elsewhere cores= raises (tested below)
EPISODE = 30  # [steps] so that the steps below cross an autoreset


def usable() -> list[int]:
    return sorted(os.sched_getaffinity(0))


def run(cores, steps: int = 40):
    """Observations, rewards, flags and infos of 4 envs in 3 workers, step by step."""
    envs = make_batch("tinyrace/CarRacing-v0", 4, 3, cores=cores, max_episode_steps=EPISODE)
    try:
        pinned = [os.sched_getaffinity(p.pid) for p in envs._workers.processes]
        results = [envs.reset(seed=5)]
        rng = np.random.default_rng(0)
        for _ in range(steps):
            action = rng.uniform([-1, 0, 0], [1, 1, 1], (4, 3)).astype(np.float32)
            results.append(envs.step(action))
        return pinned, results
    finally:
        envs.close()


@pytest.mark.skipif(not PINNING, reason="os.sched_setaffinity is Linux's (errors tested below)")
def test_each_worker_runs_on_its_core_and_the_results_do_not_change():
    cores = usable()
    given = [cores[-1], cores[0]]  # worker 0 on the last core, 1 on the first, 2 on the last
    pinned, results = run(given)
    assert pinned == [{given[0]}, {given[1]}, {given[0]}]
    free, expected = run(None)
    assert all(p == set(cores) for p in free)  # unpinned: every core of the parent's
    assert_same(results, expected)


@pytest.mark.skipif(not PINNING, reason="os.sched_setaffinity is Linux's (errors tested below)")
@pytest.mark.parametrize(
    "cores, shown",
    [
        ([10**6], "[1000000]"),  # no such core here
        ([-1], "[-1]"),
        ([], "[]"),
        ("0", "'0'"),
        ([True], "[True]"),
        ([0.0], "[0.0]"),
        (0, "0"),
        ({0}, "{0}"),  # unordered: which worker gets which core would be arbitrary
    ],
)
def test_cores_that_are_no_list_of_this_process_cores_are_refused(cores, shown):
    with pytest.raises(ConfigError) as raised:
        make_batch("tinyrace/CarRacing-v0", 2, 1, cores=cores)
    message = str(raised.value)
    assert "cores" in message and shown in message
    assert str(usable()) in message  # what is allowed: the cores this process may run on


@pytest.mark.skipif(not PINNING, reason="os.sched_setaffinity is Linux's (errors tested below)")
def test_cores_without_worker_processes_are_refused():
    with pytest.raises(ConfigError, match="workers=0 there are none"):
        make_batch("tinyrace/CarRacing-v0", 2, 0, cores=usable()[:1])


def test_cores_where_the_platform_cannot_pin_are_refused(monkeypatch):
    monkeypatch.delattr(os, "sched_setaffinity", raising=False)
    with pytest.raises(ConfigError, match=r"cores: got \[0\]; .*needs os.sched_setaffinity"):
        make_batch("tinyrace/CarRacing-v0", 2, 1, cores=[0])


@pytest.mark.skipif(not PINNING, reason="os.sched_setaffinity is Linux's (errors tested below)")
def test_the_vector_entry_point_passes_cores_on():
    import gymnasium as gym

    core = usable()[-1]
    envs = gym.make_vec(
        "tinyrace/CarRacing-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        workers=2,
        cores=[core],
    )
    try:
        assert [os.sched_getaffinity(p.pid) for p in envs._workers.processes] == [{core}] * 2
    finally:
        envs.close()
