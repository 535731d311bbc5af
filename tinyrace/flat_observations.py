"""Dict observations for Stable-Baselines3, which takes no nested dicts: each entry that is
not an array (the ``cones`` sensor's dict, a count) flattened into one. ``tinyrace train``'s
envs are flattened so (``tinyrace.train.envs.FlatEntries``), and ``tinyrace.sb3.ModelDriver``
flattens a saved model's observations the same way. Gymnasium only: no SB3 import."""

from __future__ import annotations

from typing import Any

from gymnasium import spaces


def nested_entries(space: spaces.Dict) -> dict[str, spaces.Space[Any]]:
    """The entries of a dict space that are not arrays (the ``cones`` sensor's dict, a count)."""
    return {k: s for k, s in space.spaces.items() if not isinstance(s, spaces.Box)}


def flat_space(space: spaces.Dict) -> spaces.Dict:
    """``space`` with each entry that is not an array flattened into one."""
    nested = nested_entries(space)
    return spaces.Dict(
        {k: spaces.flatten_space(s) if k in nested else s for k, s in space.spaces.items()}
    )


def flat_observation(
    nested: dict[str, spaces.Space[Any]], observation: dict[str, Any]
) -> dict[str, Any]:
    """A dict observation with its ``nested`` entries (``nested_entries``) flattened."""
    return {
        key: spaces.flatten(nested[key], value) if key in nested else value
        for key, value in observation.items()
    }
