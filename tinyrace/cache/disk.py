"""Cache files: named numpy arrays and a few plain values, memory-mapped read-only.

A process that maps an entry shares its pages with every other process that maps it (the
operating system's page cache), so envs in several worker processes hold one copy of a
track's large read-only data. One file per entry, ``<key>.npc``, in the cache folder:

    header (HEADER bytes): magic, format, header size, tinyrace version, machine tag,
                           key, payload length, payload sha256, meta length
    payload:               meta (JSON: the values and where each array lies), then the
                           arrays, each at a multiple of ALIGN bytes

An entry is trusted only when every header field is the one expected and the payload's
length and keyed checksum match (an HMAC-SHA256 of the header and payload under the
folder's own random key, ``KEY_FILE``, which only tinyrace writes): a corrupt, truncated,
foreign (other tinyrace version or machine), misnamed or hand-made file is rebuilt.
Writers write a temporary file and rename it into place (``os.replace``), under a lock
file where the platform has ``fcntl``: two processes building one entry at once never
leave a mixed file, and the second waits for the first (at most ``LOCK_WAIT`` seconds,
then it builds its own copy in memory, and the warning names the holder's process) and
maps its result. Past ``max_bytes`` the least recently used entries are removed.

Only regular files are read, mapped or locked (opened without blocking and without
following links): a FIFO, device, folder or link at an entry's name is an ``OSError``
(the caller shares in memory) and is never removed. Only files the cache writes (named
``<64 hex digits>.npc`` / ``.lock``, or ``.tmp-*.npc``, and starting as it writes them)
are ever removed, by ``trim`` and ``clear``.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import hmac
import json
import mmap
import os
import platform
import re
import stat
import struct
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.cache.files import (
    KEY_BYTES,
    KEY_FILE,
    NotRegular,
    check_replaceable,
    folder_key,
    mac,
    open_regular,
)
from tinyrace.errors import file_kind

MAGIC = b"TINYRACE-CACHE\x00\x00"  # 16 bytes
FORMAT = 2  # the layout of this file format (2: the checksum is keyed)
SUFFIX = ".npc"
LOCK_SUFFIX = ".lock"
TEMP_PREFIX = ".tmp-"
ALIGN = 64  # [bytes] arrays start at multiples of this
LOCK_WAIT = 120.0  # [s] the longest wait for another process's lock (config/bounds.py lists it)
ENTRY_NAME = re.compile(r"[0-9a-f]{64}\.npc")  # what the cache names its files
LOCK_NAME = re.compile(r"[0-9a-f]{64}\.lock")
TEMP_NAME = re.compile(r"\.tmp-[a-z0-9_]{6,16}\.npc")  # tempfile.mkstemp's names
# magic, format, header size, version, machine, key, payload length, sha256, meta length
_HEADER = struct.Struct("<16sII32s32s64sQ32sQ")
HEADER = _HEADER.size

Arrays = dict[str, np.ndarray]


def machine_tag() -> str:
    """32 hex chars naming what the bytes of an entry depend on besides its key: byte
    order, processor, Python, numpy and OpenCV versions, and the host."""
    try:
        import cv2

        opencv = str(cv2.__version__)
    except ImportError:  # pragma: no cover - cv2 is a dependency
        opencv = "-"
    parts = (sys.byteorder, platform.machine(), platform.python_version(), np.__version__,
             opencv, platform.node())  # fmt: skip
    return hashlib.sha256("|".join(parts).encode()).hexdigest()[:32]


class LockHeld(OSError):
    """Another process held an entry's lock past ``LOCK_WAIT``."""


@dataclass(frozen=True)
class Entry:
    """What an entry holds: plain JSON ``values`` and named arrays."""

    values: Any
    arrays: Arrays


def path_of(folder: Path, key: str) -> Path:
    return folder / f"{key}{SUFFIX}"


def read(folder: Path, key: str, version: str) -> Entry | None:
    """The entry ``key`` mapped read-only, or None when there is none or it is not to be
    trusted (see the module docstring); an untrusted regular file is removed. A name that
    is not a regular file raises ``NotRegular`` (an OSError) and is left alone."""
    path = path_of(folder, key)
    try:
        fd = open_regular(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    try:
        size = os.fstat(fd).st_size
        ours = size == 0 or os.pread(fd, len(MAGIC), 0) == MAGIC  # else someone else's file
        mapped = mmap.mmap(fd, 0, access=mmap.ACCESS_READ) if size >= HEADER else None
    finally:
        os.close(fd)
    entry = None if mapped is None else _trusted(mapped, key, version, folder_key(folder))
    if entry is None:
        if mapped is not None:
            mapped.close()
        if not ours:
            raise NotRegular(errno.EINVAL, "not a file of the cache (left alone)", str(path))
        _remove(path)
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # recently used: removed last
    return entry


def _trusted(mapped: mmap.mmap, key: str, version: str, secret: bytes) -> Entry | None:
    fields = _HEADER.unpack_from(mapped, 0)
    magic, fmt, header, file_version, machine, file_key, length, checksum, meta_length = fields
    expected = (MAGIC, FORMAT, HEADER, _text(version, 32), machine_tag().encode(), key.encode())
    if (magic, fmt, header, file_version, machine, file_key) != expected:
        return None
    if len(mapped) != HEADER + length or meta_length > length:
        return None
    payload = memoryview(mapped)[HEADER:]
    try:
        unsigned = _HEADER.pack(*fields[:7], bytes(32), meta_length)
        if not hmac.compare_digest(mac(secret, [unsigned, payload]), checksum):
            return None
        meta = json.loads(bytes(payload[:meta_length]))
        arrays = {
            name: _array(mapped, np.dtype(dtype), tuple(shape), HEADER + offset)
            for name, dtype, shape, offset in meta["arrays"]
        }
    except (ValueError, KeyError, TypeError):
        return None
    finally:
        payload.release()
    return Entry(meta["values"], arrays)


def _array(mapped: mmap.mmap, dtype: np.dtype[Any], shape: tuple[int, ...], at: int) -> np.ndarray:
    """A read-only array of the mapped file (an empty one needs no bytes of it)."""
    count = int(np.prod(shape))
    if count == 0:
        array = np.zeros(shape, dtype)
        array.setflags(write=False)
        return array
    if at + count * dtype.itemsize > len(mapped):
        raise ValueError("an array past the end of the file")
    return np.frombuffer(mapped, dtype, count, at).reshape(shape)


def write(folder: Path, key: str, version: str, entry: Entry) -> Path:
    """Write ``entry`` as ``key`` (a temporary file renamed into place); OSError when the
    folder cannot take it."""
    folder.mkdir(parents=True, exist_ok=True)
    meta, layout = _layout(entry)
    length = layout[-1][2] if layout else len(meta)
    fields = (MAGIC, FORMAT, HEADER, _text(version, 32), machine_tag().encode(), key.encode(),
              length)  # fmt: skip
    unsigned = _HEADER.pack(*fields, bytes(32), len(meta))
    signature = mac(folder_key(folder), [unsigned, *_payload(meta, layout)])
    header = _HEADER.pack(*fields, signature, len(meta))
    target = path_of(folder, key)
    check_replaceable(target)
    handle, temp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=SUFFIX, dir=folder)
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(header)
            for chunk in _payload(meta, layout):
                file.write(chunk)
        os.replace(temp, target)
    except BaseException:
        _remove(Path(temp))
        raise
    return target


def _layout(entry: Entry) -> tuple[bytes, list[tuple[np.ndarray, int, int]]]:
    """The meta JSON and each array with its payload offset and end."""
    arrays = [(name, np.ascontiguousarray(a)) for name, a in entry.arrays.items()]
    start = 0  # the meta's length depends on the offsets and they on it: settle it
    while True:
        described, layout, offset = [], [], _aligned(start)
        for name, array in arrays:
            described.append([name, array.dtype.str, list(array.shape), offset])
            layout.append((array, offset, offset + array.nbytes))
            offset = _aligned(offset + array.nbytes)
        meta = json.dumps({"values": entry.values, "arrays": described}).encode()
        if len(meta) <= _aligned(start):
            return meta, layout
        start = len(meta)


def _payload(
    meta: bytes, layout: list[tuple[np.ndarray, int, int]]
) -> Iterator[bytes | memoryview]:
    yield meta
    position = len(meta)
    for array, offset, end in layout:
        yield bytes(offset - position)
        yield array.reshape(-1).view(np.uint8).data if array.size else b""
        position = end


def _aligned(offset: int) -> int:
    return -(-(HEADER + offset) // ALIGN) * ALIGN - HEADER


def _text(text: str, size: int) -> bytes:
    return text.encode()[:size].ljust(size, b"\x00")


@contextlib.contextmanager
def locked(folder: Path, key: str) -> Iterator[None]:
    """Hold the entry's lock file while building it (where the platform has ``fcntl``;
    elsewhere the rename alone keeps the file whole). A lock another process holds past
    ``LOCK_WAIT`` seconds raises ``LockHeld`` naming that process."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{key}{LOCK_SUFFIX}"
    fd = open_regular(path, os.O_RDWR | os.O_CREAT)
    try:
        held = os.pread(fd, 33, 0)
        if held and not held.strip().isdigit():  # a file of someone else's: never truncated
            raise NotRegular(errno.EINVAL, "not a lock file of the cache (left alone)", str(path))
        deadline = time.monotonic() + LOCK_WAIT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    raise LockHeld(
                        errno.EAGAIN,
                        f"its lock is held by {_holder(fd)} for more than {LOCK_WAIT:g} s",
                        str(path),
                    ) from None
                time.sleep(0.05)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)  # who holds it, for a waiter's message
        try:
            yield
        finally:
            if not path_of(folder, key).exists():  # nothing stored: no lock file left behind
                _remove(path)
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def _holder(fd: int) -> str:
    """The process that wrote the lock file ``fd`` (its id), as far as it says."""
    text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    return f"process {text}" if text.isdigit() else "another process"


def entries(folder: Path) -> list[Path]:
    """The cache files of ``folder`` (regular files named as the cache names them, starting
    with its MAGIC), least recently used first."""
    found = []
    for path in _names(folder, ENTRY_NAME):
        with contextlib.suppress(OSError):
            info = os.lstat(path)
            if stat.S_ISREG(info.st_mode) and _written_here(path, ENTRY_NAME):
                found.append((info.st_mtime, path))
    return [path for _, path in sorted(found)]


def _names(folder: Path, pattern: re.Pattern[str]) -> list[Path]:
    try:
        if not stat.S_ISDIR(os.stat(folder).st_mode):
            return []
        return [folder / n for n in os.listdir(folder) if pattern.fullmatch(n)]
    except (OSError, ValueError):
        return []


def trim(folder: Path, max_bytes: int) -> None:
    """Remove the least recently used entries until the folder's entries fit ``max_bytes``
    (a process that has one mapped keeps it until it lets go)."""
    files = entries(folder)
    sizes = [_size(path) for path in files]
    total = sum(sizes)
    for path, size in zip(files, sizes, strict=True):
        if total <= max_bytes:
            break
        _remove(path)
        lock = path.with_suffix(LOCK_SUFFIX)
        if _written_here(lock, LOCK_NAME):
            _remove(lock)
        total -= size


def unusable(folder: Path) -> str | None:
    """Why ``folder`` cannot be a cache folder that is listed or cleared: a part of its path
    that is no folder, or a folder that cannot be read; None for a folder that can be read,
    or one that does not exist yet (nothing is cached there)."""
    for part in (*reversed(folder.parents), folder):
        try:
            mode = os.stat(part).st_mode
        except FileNotFoundError:
            return None
        except (OSError, ValueError) as error:
            return f"{part} cannot be read ({_reason(error)})"
        if not stat.S_ISDIR(mode):
            return f"{part} is {file_kind(mode)}, not a folder"
    try:
        with os.scandir(folder):
            pass
    except OSError as error:
        return f"{folder} cannot be read ({_reason(error)})"
    return None


def _reason(error: BaseException) -> str:
    return (getattr(error, "strerror", None) or str(error)).rstrip(".")


def clear(folder: Path, failed: list[OSError] | None = None) -> int:
    """Remove every cache file, lock file, leftover temporary file and the key of ``folder``; the
    number of entries removed. Only regular files the cache wrote are removed: named as it
    names them and, for entries and temporary files, starting with its MAGIC (a lock file
    holds at most a process id). Nothing else in the folder is touched. An entry that cannot
    be removed (a read-only folder) is left, its error added to ``failed``."""
    removed = 0
    for pattern in (ENTRY_NAME, TEMP_NAME, LOCK_NAME):
        for path in _names(folder, pattern):
            if _written_here(path, pattern):
                try:
                    path.unlink()
                except FileNotFoundError:  # removed meanwhile (another clear, a trim)
                    continue
                except OSError as error:
                    if failed is not None and pattern is ENTRY_NAME:
                        failed.append(error)
                    continue
                removed += pattern is ENTRY_NAME
    key = folder / KEY_FILE
    with contextlib.suppress(OSError, ValueError):
        if stat.S_ISREG(os.lstat(key).st_mode) and os.lstat(key).st_size == KEY_BYTES:
            _remove(key)  # the folder's key, which only the cache writes
    return removed


def _written_here(path: Path, pattern: re.Pattern[str]) -> bool:
    """Whether the regular file ``path`` is one the cache writes (see ``clear``)."""
    try:
        fd = open_regular(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        head = os.pread(fd, len(MAGIC) + 1, 0)
        size = os.fstat(fd).st_size
    finally:
        os.close(fd)
    if pattern is LOCK_NAME:
        return size <= 32 and (not head or head.strip().isdigit())
    return head.startswith(MAGIC) or (pattern is TEMP_NAME and size == 0)


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        path.unlink()
