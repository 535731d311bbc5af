"""Read-only track data that envs share: within a process, and across processes on disk.

Envs of the same fixed track hold the same loaded track, ground textures and lidar tables.
``shared(key, build)`` makes each of them once per process, keyed by content (the digest of
the loaded track and the knobs that shape the data; ``digest.py``): while one env holds it,
every other env asking with the same key gets the same object, its arrays read-only
(``flags.writeable`` False). Given a ``codec`` and a ``Settings`` whose ``max_bytes`` is
above 0, a large entry also goes to a file in the cache folder (``disk.py``) that every
process maps read-only: worker processes of a vector env share its pages.

The cache folder is the config's ``cache.dir``, else ``$TINYRACE_CACHE_DIR``, else
``$XDG_CACHE_HOME/tinyrace``, else ``~/.cache/tinyrace``; never a track's folder.
``tinyrace cache info`` lists it, ``tinyrace cache clear`` empties it.
"""

from __future__ import annotations

import os
import warnings
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, Protocol, TypeVar

from tinyrace.cache import disk
from tinyrace.cache.digest import digest, freeze
from tinyrace.errors import ConfigError, Problem

T = TypeVar("T")
DIR_VARIABLE = "TINYRACE_CACHE_DIR"  # environment variable: the cache folder
MIN_DISK_BYTES = 1 << 20  # [bytes] smaller entries stay in memory (rebuilding them is cheap)
DEFAULT_MAX_BYTES = 2 << 30  # [bytes] the folder's entries at most, by default

try:
    VERSION = version("tinyrace")
except PackageNotFoundError:  # pragma: no cover - a source tree never installed
    VERSION = "0+unknown"

_live: weakref.WeakValueDictionary[str, Any] = weakref.WeakValueDictionary()
_contents: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
_code: dict[str, str] = {}
_warned: set[str] = set()


@dataclass(frozen=True)
class Settings:
    """Where shared data goes on disk, and how much of it."""

    folder: Path
    max_bytes: int = DEFAULT_MAX_BYTES  # [bytes] 0: share within each process only


def default_folder() -> Path:
    """``$TINYRACE_CACHE_DIR``, else ``$XDG_CACHE_HOME/tinyrace``, else ``~/.cache/tinyrace``.
    A ConfigError when the variable names no folder the system can have."""
    return chosen_folder()[0]


def chosen_folder() -> tuple[Path, Problem]:
    """``default_folder()`` and where it came from, as the Problem that names it (its
    source, key and value; ``allowed`` empty): the environment variable as it is set, or
    ``<default>`` for ``~/.cache/tinyrace``."""
    chosen = os.environ.get(DIR_VARIABLE)
    if chosen:
        where = Problem("<environment>", f"${DIR_VARIABLE}", chosen, "")
        return folder_of(chosen, where.source, where.path), where
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg:
        where = Problem("<environment>", "$XDG_CACHE_HOME", xdg, "")
        return folder_of(xdg, where.source, where.path) / "tinyrace", where
    folder = Path.home() / ".cache" / "tinyrace"
    return folder, Problem("<default>", "cache folder", str(folder), "")


def folder_of(text: str, source: str, key: str) -> Path:
    """The cache folder ``text`` names (``~`` and ``~user`` expanded); a ConfigError naming
    ``source`` and ``key`` when it holds a NUL byte or names a user this system lacks."""
    allowed = None
    if "\x00" in text:
        allowed = "expected a folder name without a NUL byte"
    else:
        try:
            return Path(text).expanduser()
        except RuntimeError:  # ~nosuchuser
            user = text.split("/", 1)[0]
            allowed = f"expected a folder; {user} names no user of this system"
    raise ConfigError(Problem(source, key, text, allowed))


def folder_problems(text: str, source: str, key: str) -> list[Problem]:
    """``folder_of``'s problems, as a list (empty when ``text`` names a folder)."""
    try:
        folder_of(text, source, key)
    except ConfigError as error:
        return error.problems
    return []


class Codec(Protocol[T]):
    """Turns a value into a cache entry (named arrays and JSON values) and back."""

    def encode(self, value: T) -> disk.Entry: ...

    def decode(self, entry: disk.Entry) -> T: ...


def shared(
    key: object,
    build: Callable[[], T],
    settings: Settings | None = None,
    codec: Codec[T] | None = None,
) -> T:
    """The value of ``key`` (any content ``digest`` takes: names, numbers, track digests),
    made by ``build`` when no env of this process holds it (nor, with ``settings`` and
    ``codec``, the cache folder). Its arrays are read-only."""
    name = digest((VERSION, key))
    value: T | None = _live.get(name)
    if value is None:
        if settings is not None and codec is not None and settings.max_bytes > 0:
            value = _through_disk(name, build, settings, codec)
        else:
            value = _built(build)
        _live[name] = value
    return value


def content(value: object) -> str:
    """``digest(value)``, computed once per object (a shared track, read-only)."""
    found = _contents.get(value)
    if found is None:
        found = _contents[value] = digest(value)
    return found


def code(*files: str) -> str:
    """A digest of the source files (``__file__`` of the modules) that make an entry, for
    its key: an entry made by other code is never taken for this code's."""
    joined = "|".join(files)
    found = _code.get(joined)
    if found is None:
        found = _code[joined] = digest(tuple(Path(f).read_bytes() for f in files))
    return found


def forget() -> None:
    """Let go of every value this process shares (envs that hold one keep it); the next
    ``shared`` call builds anew, or maps the cache file. For tests and benchmarks."""
    _live.clear()


def _built(build: Callable[[], T]) -> T:
    value = build()
    freeze(value)
    return value


def _through_disk(name: str, build: Callable[[], T], settings: Settings, codec: Codec[T]) -> T:
    folder = settings.folder
    try:
        entry = disk.read(folder, name, VERSION)
        if entry is None:
            with disk.locked(folder, name):
                entry = disk.read(folder, name, VERSION)  # another process may have built it
                if entry is None:
                    value = _built(build)
                    entry = _stored(value, name, settings, codec)
                    if entry is None:
                        return value
        return codec.decode(entry)
    except disk.LockHeld as error:  # a builder that hangs: this process builds its own copy
        warnings.warn(
            f"tinyrace: the cache entry {error.filename} is being built elsewhere ({error}); "
            "this process builds its own copy in memory",
            RuntimeWarning,
            stacklevel=3,
        )
    except OSError as error:
        _warn_once(folder, error)
    except (KeyError, IndexError, ValueError, TypeError) as error:  # an entry of other code
        _warn_once(folder, OSError(f"an entry does not decode: {type(error).__name__} {error}"))
    return _built(build)


def _stored(value: T, name: str, settings: Settings, codec: Codec[T]) -> disk.Entry | None:
    """``value`` written to the cache folder and mapped back, or None when it is too small
    to be worth a file or too large for the folder."""
    encoded = codec.encode(value)
    size = sum(array.nbytes for array in encoded.arrays.values())
    if not MIN_DISK_BYTES <= size <= settings.max_bytes:
        return None
    disk.write(settings.folder, name, VERSION, encoded)
    disk.trim(settings.folder, settings.max_bytes)
    return disk.read(settings.folder, name, VERSION)


def _warn_once(folder: Path, error: OSError) -> None:
    if str(folder) not in _warned:
        _warned.add(str(folder))
        warnings.warn(
            f"tinyrace: cannot use the cache folder {folder} ({error}); envs share their "
            f"tracks within each process only (set cache.dir or ${DIR_VARIABLE})",
            RuntimeWarning,
            stacklevel=3,
        )
