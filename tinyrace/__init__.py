"""tinyrace: fast 2D driving environments for reinforcement learning and driving-software tests.

Importing tinyrace registers its Gymnasium environments and the parts of installed
plugins: each entry point of the group ``tinyrace.parts`` is loaded, and called when it is
a function (one that registers parts, as ``tinyrace.sensors.registry.register`` does).
It imports nothing heavy (no pymunk, cv2 or window library) unless a plugin does.

The built-in parts need no loading: each registry (track sources, car models, sensor
types, rule parts, drivers) holds its built-in parts as soon as any layer imports it, and
the config classes of the built-in track types and sensor types are in the config
families the loader, ``tinyrace validate`` and the YAML reference read from the start.
``load_parts()`` imports every registry at once (for a tool that lists them all).
"""

from importlib.metadata import PackageNotFoundError, entry_points, version

from gymnasium import logger
from gymnasium.envs.registration import register, registry

PLUGIN_GROUP = "tinyrace.parts"  # the entry point group of third-party parts

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


def load_plugins() -> list[str]:
    """Load every entry point of ``PLUGIN_GROUP`` (calling those that are functions); the
    names of those loaded. A plugin that fails is reported with a warning naming it, and
    the others load."""
    loaded = []
    for point in entry_points(group=PLUGIN_GROUP):
        try:
            found = point.load()
            if callable(found):
                found()
        except Exception as exc:  # a broken plugin must not break tinyrace
            logger.warn(f"tinyrace plugin {point.name!r} ({point.value}) failed to load: {exc!r}")
            continue
        loaded.append(point.name)
    return loaded


def load_parts() -> None:
    """Import every built-in registry (each fills itself with its parts when imported)."""
    import tinyrace.cars.registry
    import tinyrace.drivers
    import tinyrace.episodes.rules
    import tinyrace.sensors.registry
    import tinyrace.tracks.registry  # noqa: F401


load_plugins()
