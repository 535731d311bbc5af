"""The vector entry points of tinyrace's ids: BatchVectorEnvs of ``gym.make`` envs."""

from __future__ import annotations

import functools
import os
from typing import Any

import gymnasium as gym

from tinyrace.config.bounds import MAX_ENVS
from tinyrace.vector.batched import NUMPY_FROM
from tinyrace.vector.env import BatchVectorEnv
from tinyrace.vector.failures import check_count


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
    **kwargs: Any,
) -> BatchVectorEnv:
    """A BatchVectorEnv of ``num_envs`` copies of ``gym.make(id, **kwargs)``; ``workers=0``
    steps them all in this process, ``parent_steps=True`` a slice of them beside the
    ``workers`` processes."""
    check_count("num_envs", num_envs, 1, MAX_ENVS)
    maker = functools.partial(_make, id, kwargs)
    return BatchVectorEnv(
        [maker] * num_envs,
        workers=workers,
        context=context,
        copy=copy,
        batch_physics=batch_physics,
        numpy_from=numpy_from,
        parent_steps=parent_steps,
    )


def make_carracing_vec(
    num_envs: int = 1, workers: int | None = None, **kwargs: Any
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/CarRacing-v0", vectorization_mode="vector_entry_point")``."""
    return make_batch("tinyrace/CarRacing-v0", num_envs, _workers(num_envs, workers), **kwargs)


def make_tinyrace_vec(
    num_envs: int = 1, workers: int | None = None, **kwargs: Any
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/TinyRace-v0", vectorization_mode="vector_entry_point")``."""
    return make_batch("tinyrace/TinyRace-v0", num_envs, _workers(num_envs, workers), **kwargs)


def _workers(num_envs: int, workers: int | None) -> int:
    """One worker process per core by default, never more than envs."""
    check_count("num_envs", num_envs, 1, MAX_ENVS)
    return workers if workers is not None else max(1, min(num_envs, os.cpu_count() or 1))


def _make(id: str, kwargs: dict[str, Any]) -> gym.Env:
    # pickled by reference to this module: a spawned worker imports tinyrace, registering its ids
    return gym.make(id, **kwargs)
