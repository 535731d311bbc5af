"""``tinyrace cache``: what the folder of shared track data holds, and emptying it.

The folder is ``--dir``, else the one ``chosen_folder`` says; one that is a file or a
device, lies under one or cannot be read is a ConfigError naming where it came from (it
holds no "0 files").
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from tinyrace.cache import chosen_folder, disk, folder_of
from tinyrace.errors import ConfigError, Problem


def info(chosen: str | None) -> list[str]:
    """The lines ``tinyrace cache info`` prints: the folder, its files and their size."""
    folder, _ = _folder(chosen)
    files = disk.entries(folder)
    size = sum(path.stat().st_size for path in files)
    return [
        f"cache folder: {folder}",
        f"{len(files)} file(s), {size / 2**20:.1f} MB (cache.max_size caps it; default 2048 MB)",
        "empty it: tinyrace cache clear",
    ]


def clear(chosen: str | None) -> list[str]:
    """Empty the folder of the cache's own files (``disk.clear``); the line to print. Files
    it could not remove (a read-only folder) are a ConfigError saying how many and why."""
    folder, where = _folder(chosen)
    failed: list[OSError] = []
    removed = disk.clear(folder, failed)
    if failed:
        reason = failed[0].strerror or str(failed[0])
        allowed = (
            f"expected a folder whose files can be removed: {len(failed)} cache file(s) "
            f"left in {folder} ({reason}; removed {removed})"
        )
        raise ConfigError(dataclasses.replace(where, allowed=allowed))
    return [f"removed {removed} cache file(s) from {folder}"]


def _folder(chosen: str | None) -> tuple[Path, Problem]:
    """The folder (``--dir`` when given) and the Problem that names where it came from."""
    if chosen:
        where = Problem("<command line>", "--dir", chosen, "")
        folder = folder_of(chosen, where.source, where.path)
    else:
        folder, where = chosen_folder()
    unusable = disk.unusable(folder)
    if unusable is not None:  # a file, a device or a folder it cannot list: not "0 file(s)"
        raise ConfigError(
            dataclasses.replace(where, allowed=f"expected a readable folder: {unusable}")
        )
    return folder, where
