"""Paths a config names (images, data files) stay inside the config's folder.

``..``, absolute paths and symlinks leading out of the folder are refused unless the config
opts in with ``files.paths_outside_folder: true``; a NUL byte is refused always. Track
sources call ``inside_folder`` for every file name they read from a config.
"""

from __future__ import annotations

from pathlib import Path, PurePath

from tinyrace.errors import ConfigError, Problem

OPT_IN_KEY = "files.paths_outside_folder"


def inside_folder(value: str, folder: Path, allow_outside: bool, source: str, where: str) -> Path:
    """``value`` resolved against ``folder``; a ConfigError (source, where) if it leaves it."""
    reason = _why_outside(value, folder, allow_outside)
    if reason is not None:
        raise ConfigError(Problem(source, where, value, reason))
    return (folder / value).resolve()


def _why_outside(value: str, folder: Path, allow_outside: bool) -> str | None:
    if "\x00" in value:
        return "expected a file name without a NUL byte"
    if allow_outside:
        return None
    outside = (
        f"expected a path inside {folder} (or {OPT_IN_KEY}: true, a section of the env "
        "config: top level in a track.yaml, under env: in an experiment)"
    )
    pure = PurePath(value)
    if pure.is_absolute():
        return f"{outside}; this one is absolute"
    if ".." in pure.parts:
        return f"{outside}; this one climbs out with '..'"
    try:
        resolved = (folder / value).resolve()
        base = folder.resolve()
    except (OSError, ValueError, RuntimeError) as exc:  # a symlink loop, a name too long
        return f"expected a file name the system can resolve ({exc})"
    if not resolved.is_relative_to(base):
        return f"{outside}; a symlink leads to {resolved}"
    return None
