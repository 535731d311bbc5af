"""The vector entry points of tinyrace's ids: BatchVectorEnvs of ``gym.make`` envs."""

from __future__ import annotations

import functools
import os
from collections.abc import Sequence
from typing import Any

import gymnasium as gym

from tinyrace.config.bounds import MAX_ENVS
from tinyrace.vector.batched import NUMPY_FROM
from tinyrace.vector.env import BatchVectorEnv
from tinyrace.vector.failures import check_autoreset, check_count, check_flag


def make_batch(
    id: str,
    num_envs: int,
    workers: int = 2,
    *,
    context: str | None = None,
    copy: bool = True,
    batch_physics: bool = True,
    numpy_from: int = NUMPY_FROM,
    parent_steps: bool = False,
    cores: Sequence[int] | None = None,
    autoreset_mode: Any = "NextStep",
    **kwargs: Any,
) -> BatchVectorEnv:
    """A BatchVectorEnv of ``num_envs`` copies of ``gym.make(id, **kwargs)``; ``workers=0``
    steps them all in this process, ``parent_steps=True`` a slice of them beside the
    ``workers`` processes, ``cores`` pins the worker processes (``BatchVectorEnv``).
    ``autoreset_mode`` is Gymnasium's: NEXT_STEP, the one mode a BatchVectorEnv has."""
    check_count("num_envs", num_envs, 1, MAX_ENVS)
    check_autoreset(autoreset_mode)
    maker = functools.partial(_make, id, kwargs)
    return BatchVectorEnv(
        [maker] * num_envs,
        workers=workers,
        context=context,
        copy=copy,
        batch_physics=batch_physics,
        numpy_from=numpy_from,
        parent_steps=parent_steps,
        cores=cores,
    )


def make_carracing_vec(
    num_envs: int = 1,
    workers: int | None = None,
    parent_steps: bool | None = None,
    **kwargs: Any,
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/CarRacing-v0", vectorization_mode="vector_entry_point")``."""
    workers, parent_steps = layout(num_envs, workers, parent_steps)
    return make_batch(
        "tinyrace/CarRacing-v0", num_envs, workers, parent_steps=parent_steps, **kwargs
    )


def make_tinyrace_vec(
    num_envs: int = 1,
    workers: int | None = None,
    parent_steps: bool | None = None,
    **kwargs: Any,
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/TinyRace-v0", vectorization_mode="vector_entry_point")``."""
    workers, parent_steps = layout(num_envs, workers, parent_steps)
    return make_batch(
        "tinyrace/TinyRace-v0", num_envs, workers, parent_steps=parent_steps, **kwargs
    )


def layout(num_envs: int, workers: int | None, parent_steps: bool | None) -> tuple[int, bool]:
    """(worker processes, whether the parent steps a slice too). By default one slice per
    core this process may run on (``usable_cores``), never more than envs, the parent
    stepping one of them (no core idles while the parent waits, benchmarks/README.md);
    ``parent_steps=False``: one worker process per core. Given ``workers``, that many
    processes, and the parent steps only if asked."""
    check_count("num_envs", num_envs, 1, MAX_ENVS)
    if parent_steps is not None:
        check_flag("parent_steps", parent_steps)
    if workers is not None:
        return workers, bool(parent_steps)
    slices = max(1, min(num_envs, usable_cores()))
    if parent_steps is False or slices == 1:
        return slices, False
    return slices - 1, True


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity where the OS has one (``taskset``,
    a container's cpuset, a Slurm allocation), not every core of the machine
    (``os.cpu_count``), which would start a worker per core of a large host on the few
    cores a job was given."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def _make(id: str, kwargs: dict[str, Any]) -> gym.Env:
    # pickled by reference to this module: a spawned worker imports tinyrace, registering its ids
    return gym.make(id, **kwargs)
