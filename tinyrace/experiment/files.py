"""Writing the files of a run folder: never through a link, never into what is not a file.

A run's files (results.json, episodes.csv, traces, pictures, report.html) are written whole
to a temporary file beside the target and renamed over it (``os.replace``): a symbolic or
hard link at the target's name is never followed, so the file it points to is never
changed. A target that is a symbolic link, a folder, a FIFO or a device is refused with a
ConfigError naming it (tinyrace removes nothing it did not write).
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Mapping
from pathlib import Path

from tinyrace.errors import ConfigError, Problem, file_kind

TEMP_PREFIX = ".tinyrace-"


def write_file(path: Path, data: bytes) -> Path:
    """Write ``data`` as ``path`` (a new file, or one replacing the regular file there)."""
    write_files({path: data})
    return path


def write_files(files: Mapping[Path, bytes]) -> None:
    """Write each file whole under a temporary name beside it, then rename them all: a
    failure (or Ctrl-C) before the renames leaves every old file as it was, and the renames
    take microseconds. A folder where no file can be made is a ConfigError naming it."""
    for path in files:
        check_writable(path)
    temps: dict[Path, str] = {}
    try:
        for path, data in files.items():
            temps[path] = _temp_copy(path, data)
        for path, temp in temps.items():
            os.replace(temp, path)
    except BaseException:
        for temp in temps.values():
            with contextlib.suppress(OSError):
                os.unlink(temp)
        raise


def _temp_copy(path: Path, data: bytes) -> str:
    """``data`` written to a new temporary file beside ``path``; its name."""
    try:
        handle, temp = tempfile.mkstemp(prefix=TEMP_PREFIX, dir=path.parent)
    except OSError as exc:  # refused, read-only, gone
        allowed = f"expected a folder where files can be written ({exc.strerror})"
        raise ConfigError(Problem(str(path.parent), "", path.name, allowed)) from None
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(data)
        os.chmod(temp, 0o644 & ~_umask())
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temp)
        raise
    return temp


def write_text(path: Path, text: str) -> Path:
    """``write_file`` of UTF-8 text. A file name that is not UTF-8 (Python keeps its bytes
    as lone surrogates) is written escaped (``caf\\udce9.yaml``), so the file stays UTF-8."""
    return write_file(path, text.encode("utf-8", "backslashreplace"))


def check_writable(path: Path) -> None:
    """A ConfigError when ``path`` exists as anything but a regular file of its own."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISREG(info.st_mode):
        return
    kind = file_kind(info.st_mode)
    allowed = (
        f"expected a regular file or no file there, not {kind}: tinyrace never writes "
        "through a link nor removes what it did not write (move it away, or use another folder)"
    )
    raise ConfigError(Problem(str(path), "", path.name, allowed))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def unmakeable(path: Path) -> str | None:
    """Why no file can be made at ``path`` (None if one can): its nearest existing folder
    above must be a folder where this user can make a file (the folders between are made
    when it is written); tried with a temporary file, since permissions alone do not tell
    (``/proc`` lets root through)."""
    existing = next(p for p in (path.parent, *path.parent.parents) if p.exists())
    if not existing.is_dir():
        return f"expected a path in folders: {str(existing)!r} is a file"
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        return (
            f"expected a folder where a file can be made: {str(existing)!r} is not ({exc.strerror})"
        )
    return None
