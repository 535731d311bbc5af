"""tinyrace: fast 2D driving environments for reinforcement learning and driving-software tests.

Importing tinyrace registers its Gymnasium environments and does nothing else.
"""

from importlib.metadata import PackageNotFoundError, version

from gymnasium.envs.registration import register, registry

try:
    __version__ = version("tinyrace")  # one source: pyproject.toml, through the metadata
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

if "tinyrace/CarRacing-v0" not in registry:
    register(
        id="tinyrace/CarRacing-v0",
        entry_point="tinyrace.carracing:CarRacingEnv",
        vector_entry_point="tinyrace.vector:make_carracing_vec",  # the batched vector env
        max_episode_steps=1000,
        reward_threshold=900,
    )
    register(
        id="tinyrace/TinyRace-v0",
        entry_point="tinyrace.race.opponents:make_env",  # a TinyRaceEnv (with opponents: wrapped)
        vector_entry_point="tinyrace.vector:make_tinyrace_vec",
    )
