"""Several cars racing on one track: a PettingZoo ParallelEnv.

``parallel_env(environment=..., num_agents=...)`` makes a ``RaceEnv``: the cars of the
config's ``race`` section on any tinyrace track, each with its own observation (the
config's sensors, riding on that car), reward terms, termination and info. The AEC form
is PettingZoo's ``parallel_to_aec(parallel_env(...))`` (``aec_env`` here).
"""

from __future__ import annotations

from typing import Any

from tinyrace.race.env import RaceEnv, UnknownAgent


def parallel_env(**kwargs: Any) -> RaceEnv:
    """A ``RaceEnv``; keyword arguments as ``RaceEnv``'s (``environment``, ``config``,
    ``num_agents``, ``render_mode``, any config key)."""
    return RaceEnv(**kwargs)


def aec_env(**kwargs: Any) -> Any:
    """The AEC form of ``parallel_env(**kwargs)`` (PettingZoo's converter)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(**kwargs))


__all__ = ["RaceEnv", "UnknownAgent", "aec_env", "parallel_env"]
