"""The cache folder's own files, opened safely: regular files only, no link followed, and the
folder's HMAC key, which tells the cache's entries from any other file.

``open_regular`` opens without blocking (a FIFO answers at once) and without following a
link, and refuses anything but a regular file with ``NotRegular`` (an OSError: the cache
then shares in memory, and leaves the name alone). ``folder_key`` is the folder's random
key (``KEY_FILE``, mode 0600, made once by whichever process comes first).
"""

from __future__ import annotations

import errno
import hashlib
import hmac
import os
import secrets
import stat
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path

KEY_FILE = ".tinyrace-key"  # the folder's random HMAC key (KEY_BYTES bytes, mode 0600)
KEY_BYTES = 32


class NotRegular(OSError):
    """A name of the cache folder is not a regular file (a FIFO, device, folder or link)."""


def folder_key(folder: Path) -> bytes:
    """The folder's HMAC key: read from ``KEY_FILE``, or made (random, mode 0600) when the
    folder has none. An OSError when it cannot be read or made."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / KEY_FILE
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NO_FOLLOW, 0o600)
    except FileExistsError:
        pass
    else:
        handle, temp = tempfile.mkstemp(prefix=".tmp-key-", dir=folder)
        os.close(fd)  # claimed: write the key whole beside it, then move it in
        with os.fdopen(handle, "wb") as file:
            file.write(secrets.token_bytes(KEY_BYTES))
        os.replace(temp, path)
    for _ in range(20):  # another process may be moving its key in
        fd = open_regular(path, os.O_RDONLY)
        try:
            data = os.pread(fd, KEY_BYTES + 1, 0)
        finally:
            os.close(fd)
        if len(data) == KEY_BYTES:
            return data
        time.sleep(0.01)
    raise OSError(errno.EINVAL, f"expected {KEY_BYTES} bytes of key", str(path))


_NO_FOLLOW = getattr(os, "O_NOFOLLOW", 0)


def mac(secret: bytes, chunks: Iterable[bytes | memoryview]) -> bytes:
    mac = hmac.new(secret, digestmod=hashlib.sha256)
    for chunk in chunks:
        mac.update(chunk)
    return mac.digest()


def open_regular(path: Path, flags: int) -> int:
    """A descriptor of the regular file ``path`` (made with mode 0644 under ``os.O_CREAT``),
    opened without blocking on a FIFO and without following a link; ``NotRegular`` else."""
    try:
        fd = os.open(path, flags | getattr(os, "O_NONBLOCK", 0) | _NO_FOLLOW, 0o644)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENXIO, errno.EISDIR):  # a link, FIFO, folder
            raise NotRegular(exc.errno, "not a regular file", str(path)) from None
        raise
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise NotRegular(errno.EINVAL, "not a regular file (a FIFO, device or folder)", str(path))
    return fd


def check_replaceable(path: Path) -> None:
    """``NotRegular`` when something other than a regular file has the name ``path``."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise NotRegular(errno.EINVAL, "not a regular file (left alone)", str(path))
