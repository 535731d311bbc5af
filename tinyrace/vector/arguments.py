"""What a vector env's calls are given, checked: seeds, options and their reset mask,
env indices, a step's actions. Each bad value is named with what is allowed; the values
SyncVectorEnv takes come back as it would use them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import iterate

from tinyrace.errors import shown


def seeds(seed: Any, num_envs: int) -> list[int | None]:
    """One seed per env: None for each, ``seed + i`` for env ``i``, or the list given (numpy
    integers as ints, which Gymnasium's seeding refuses)."""
    if seed is None:
        return [None] * num_envs
    if isinstance(seed, int | np.integer) and not isinstance(seed, bool | np.bool_):
        return [int(seed) + i for i in range(num_envs)]
    if isinstance(seed, str | bytes) or not isinstance(seed, Sequence | np.ndarray):
        raise TypeError(
            f"seed: expected None, a whole number or a list of one per env ({num_envs}), "
            f"got {shown(seed)}"
        )
    if len(seed) != num_envs:
        raise ValueError(
            f"If seeds are passed as a list the length must match num_envs={num_envs} "
            f"but got length={len(seed)}."
        )
    return [int(s) if isinstance(s, np.integer) else s for s in seed]


def reset_options(options: Any, num_envs: int) -> tuple[dict[str, Any] | None, np.ndarray]:
    """(the options for the envs, which envs reset): ``options["reset_mask"]`` taken out of a
    copy (the caller's dict is left alone, unlike SyncVectorEnv), checked as SyncVectorEnv
    does; every env without one."""
    if options is not None and not isinstance(options, dict):
        raise TypeError(f"options: expected a dict or None, got {shown(options)}")
    if options is None or "reset_mask" not in options:
        return options, np.ones(num_envs, dtype=np.bool_)
    options = dict(options)
    mask = options.pop("reset_mask")
    if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
        raise TypeError(f"`options['reset_mask']` must be a numpy array of bools, got {mask!r}")
    if mask.shape != (num_envs,) or not mask.any():
        raise ValueError(
            f"`options['reset_mask']` must have shape `({num_envs},)` and a True value, got {mask}"
        )
    return options, mask


def env_indices(indices: Any, num_envs: int, negative: bool = False) -> list[int]:
    """``indices`` (several, or one whole number) as ints in their order, if each is an env
    (``negative``: counted from the end too, as SB3's VecEnvs take them); else a ValueError
    naming them."""
    low = -num_envs if negative else 0
    allowed = f"expected env indices from {low} to {num_envs - 1}"
    if isinstance(indices, int | np.integer):
        indices = [indices]
    try:
        chosen = list(indices)
    except TypeError:
        raise ValueError(f"indices: got {shown(indices)}; {allowed}") from None
    for index in chosen:
        whole = isinstance(index, int | np.integer) and not isinstance(index, bool | np.bool_)
        if not whole or not low <= index < num_envs:
            raise ValueError(f"indices: got {shown(indices)}; {allowed} (not {shown(index)})")
    return [int(index) % num_envs for index in chosen]


def actions_batch(
    actions: Any, space: gym.Space[Any], single: gym.Space[Any], num_envs: int, array: bool
) -> Any:
    """A step's actions as one batch to slice: an array for array spaces (``array``), else a
    list of one per env; a ValueError naming them when they are not one per env."""
    try:
        if array:
            batch: Any = np.asarray(actions)
            count = len(batch) if batch.ndim else None
        else:
            batch = list(iterate(space, actions))
            count = len(batch)
    except (TypeError, ValueError, AssertionError) as error:  # ragged, or not iterable
        raise ValueError(
            f"actions: expected one per env, {num_envs} in all, of {single}; "
            f"got {shown(actions)} ({error})"
        ) from None
    if count != num_envs:
        got = "a single value" if count is None else f"{count}"
        raise ValueError(f"expected actions for {num_envs} envs, got {got}")
    return batch
