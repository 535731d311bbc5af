"""Cache files: named numpy arrays and a few plain values, memory-mapped read-only.

A process that maps an entry shares its pages with every other process that maps it (the
operating system's page cache), so envs in several worker processes hold one copy of a
track's large read-only data. One file per entry, ``<key>.npc``, in the cache folder:

    header (HEADER bytes): magic, format, header size, tinyrace version, machine tag,
                           key, payload length, payload sha256, meta length
    payload:               meta (JSON: the values and where each array lies), then the
                           arrays, each at a multiple of ALIGN bytes

An entry is trusted only when every header field is the one expected and the payload's
length and checksum match: a corrupt, truncated, foreign (other tinyrace version or
machine) or misnamed file is rebuilt. Writers write a temporary file and rename it into
place (``os.replace``), under a lock file where the platform has ``fcntl``: two processes
building one entry at once never leave a mixed file, and the second waits for the first
and maps its result. Past ``max_bytes`` the least recently used entries are removed.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import mmap
import os
import platform
import struct
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

MAGIC = b"TINYRACE-CACHE\x00\x00"  # 16 bytes
FORMAT = 1  # the layout of this file format
SUFFIX = ".npc"
LOCK_SUFFIX = ".lock"
TEMP_PREFIX = ".tmp-"
ALIGN = 64  # [bytes] arrays start at multiples of this
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


@dataclass(frozen=True)
class Entry:
    """What an entry holds: plain JSON ``values`` and named arrays."""

    values: Any
    arrays: Arrays


def path_of(folder: Path, key: str) -> Path:
    return folder / f"{key}{SUFFIX}"


def read(folder: Path, key: str, version: str) -> Entry | None:
    """The entry ``key`` mapped read-only, or None when there is none or it is not to be
    trusted (see the module docstring); an untrusted file is removed."""
    path = path_of(folder, key)
    try:
        with open(path, "rb") as file:
            size = os.fstat(file.fileno()).st_size
            if size < HEADER:
                raise ValueError("truncated header")
            mapped = mmap.mmap(file.fileno(), 0, access=mmap.ACCESS_READ)
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        _remove(path)
        return None
    entry = _trusted(mapped, key, version)
    if entry is None:
        mapped.close()
        _remove(path)
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # recently used: removed last
    return entry


def _trusted(mapped: mmap.mmap, key: str, version: str) -> Entry | None:
    fields = _HEADER.unpack_from(mapped, 0)
    magic, fmt, header, file_version, machine, file_key, length, checksum, meta_length = fields
    expected = (MAGIC, FORMAT, HEADER, _text(version, 32), machine_tag().encode(), key.encode())
    if (magic, fmt, header, file_version, machine, file_key) != expected:
        return None
    if len(mapped) != HEADER + length or meta_length > length:
        return None
    payload = memoryview(mapped)[HEADER:]
    try:
        if hashlib.sha256(payload).digest() != checksum:
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
    hasher = hashlib.sha256()
    for chunk in _payload(meta, layout):
        hasher.update(chunk)
    header = _HEADER.pack(MAGIC, FORMAT, HEADER, _text(version, 32), machine_tag().encode(),
                          key.encode(), length, hasher.digest(), len(meta))  # fmt: skip
    handle, temp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=SUFFIX, dir=folder)
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(header)
            for chunk in _payload(meta, layout):
                file.write(chunk)
        os.replace(temp, path_of(folder, key))
    except BaseException:
        _remove(Path(temp))
        raise
    return path_of(folder, key)


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
    elsewhere the rename alone keeps the file whole)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{key}{LOCK_SUFFIX}"
    with open(path, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            if not path_of(folder, key).exists():  # nothing stored: no lock file left behind
                _remove(path)
            fcntl.flock(lock, fcntl.LOCK_UN)


def entries(folder: Path) -> list[Path]:
    """The cache files of ``folder``, least recently used first."""
    if not folder.is_dir():
        return []
    found = []
    for path in folder.glob(f"*{SUFFIX}"):
        if path.name.startswith(TEMP_PREFIX):
            continue
        with contextlib.suppress(OSError):
            found.append((path.stat().st_mtime, path))
    return [path for _, path in sorted(found)]


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
        _remove(path.with_suffix(LOCK_SUFFIX))
        total -= size


def clear(folder: Path) -> int:
    """Remove every cache file, lock file and leftover temporary file of ``folder``; the
    number of entries removed. Nothing else in the folder is touched."""
    removed = 0
    if not folder.is_dir():
        return 0
    for path in folder.iterdir():
        name = path.name
        ours = name.endswith(SUFFIX) or name.endswith(LOCK_SUFFIX)
        if ours and path.is_file():
            removed += name.endswith(SUFFIX) and not name.startswith(TEMP_PREFIX)
            _remove(path)
    return removed


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        path.unlink()
