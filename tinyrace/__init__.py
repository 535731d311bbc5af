"""tinyrace: fast 2D driving environments for reinforcement learning and driving-software tests.

Importing tinyrace registers its Gymnasium environments and does nothing else.
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

if "tinyrace/CarRacing-v0" not in registry:
    register(
        id="tinyrace/CarRacing-v0",
        entry_point="tinyrace.carracing:CarRacingEnv",
        max_episode_steps=1000,
        reward_threshold=900,
    )
    register(id="tinyrace/TinyRace-v0", entry_point="tinyrace.env:TinyRaceEnv")
