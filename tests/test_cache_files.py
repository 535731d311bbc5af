"""The cache folder of shared track data: entries mapped read-only, never trusted when
corrupt, truncated, foreign or misnamed, safe when two processes build one at once,
bounded in size, where the knobs say, emptied by ``tinyrace cache clear``."""

from __future__ import annotations

import mmap
import multiprocessing
import struct
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tinyrace import cache, cli
from tinyrace.cache import disk
from tinyrace.cache.codec import DataclassCodec
from tinyrace.cache.digest import digest
from tinyrace.config import cache_settings, load_env_config


@dataclass(frozen=True, eq=False)
class Table:
    """A stand-in for a lidar field: a large array and a few plain values."""

    values: np.ndarray
    shape: tuple[int, int]
    scale: float
    exact: np.float32
    optional: np.ndarray | None = None


CODEC = DataclassCodec(Table)
SIZE = 1 << 20  # [bytes] the smallest entry that goes to a file


def make_table(seed: int = 0) -> Table:
    values = np.random.default_rng(seed).integers(0, 255, SIZE + 1000, np.uint8)
    return Table(values, (3, 4), 0.1, np.float32(1 / 3))


class Builds:
    """A build function that counts its calls."""

    def __init__(self, seed: int = 0) -> None:
        self.calls = 0
        self.seed = seed

    def __call__(self) -> Table:
        self.calls += 1
        return make_table(self.seed)


def share(key: object, build: Builds, folder: Path, max_bytes: int = 1 << 30) -> Table:
    cache.forget()  # as a fresh process: nothing shared in memory
    return cache.shared(key, build, cache.Settings(folder, max_bytes), CODEC)


def only_entry(folder: Path) -> Path:
    (path,) = disk.entries(folder)
    return path


def root_of(array: np.ndarray) -> object:
    base: object = array
    while isinstance(base, np.ndarray):
        base = base.base
    return base.obj if isinstance(base, memoryview) else base


def assert_same(table: Table, expected: Table) -> None:
    assert np.array_equal(table.values, expected.values)
    assert (table.shape, table.scale, table.optional) == (expected.shape, expected.scale, None)
    assert type(table.exact) is np.float32 and table.exact == expected.exact


def test_an_entry_is_written_once_and_mapped_read_only(tmp_path: Path):
    build = Builds()
    first = share("table", build, tmp_path)
    again = share("table", build, tmp_path)
    assert build.calls == 1
    assert_same(again, make_table())
    assert not again.values.flags.writeable and not first.values.flags.writeable
    assert isinstance(root_of(again.values), mmap.mmap)  # pages of the file, not a copy
    with pytest.raises(ValueError, match="read-only"):
        again.values[0] = 1


def test_within_a_process_one_value_per_key_while_held(tmp_path: Path):
    cache.forget()
    settings = cache.Settings(tmp_path)
    build = Builds()
    held = cache.shared("a", build, settings, CODEC)
    assert cache.shared("a", build, settings, CODEC) is held
    assert cache.shared("b", Builds(1), settings, CODEC) is not held


def _damage_payload(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[-10] ^= 0xFF
    path.write_bytes(bytes(data))


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:-100])


def _header_field(index: int, value: bytes) -> object:
    def patch(path: Path) -> None:
        data = bytearray(path.read_bytes())
        fields = list(disk._HEADER.unpack_from(data, 0))
        fields[index] = value
        data[: disk.HEADER] = disk._HEADER.pack(*fields)
        path.write_bytes(bytes(data))

    return patch


def _other_format(path: Path) -> None:
    data = bytearray(path.read_bytes())
    struct.pack_into("<I", data, 16, disk.FORMAT + 1)
    path.write_bytes(bytes(data))


@pytest.mark.parametrize(
    "damage",
    [
        _damage_payload,
        _truncate,
        _header_field(0, b"NOT-A-CACHE-FILE"),
        _other_format,
        _header_field(3, b"0.0.0-another-version".ljust(32, b"\x00")),
        _header_field(4, b"0" * 32),  # another machine
        lambda path: path.write_bytes(b""),
        lambda path: path.write_bytes(b"x" * 100),
    ],
    ids=["corrupt", "truncated", "magic", "format", "version", "machine", "empty", "short"],
)
def test_an_untrusted_entry_is_rebuilt(tmp_path: Path, damage):
    build = Builds()
    share("table", build, tmp_path)
    path = only_entry(tmp_path)
    damage(path)
    damaged = path.read_bytes()
    foreign = damaged[: len(disk.MAGIC)] != disk.MAGIC and len(damaged) > 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = share("table", build, tmp_path)
    assert build.calls == 2
    assert_same(table, make_table())
    if foreign:  # not a file the cache wrote (no MAGIC): left alone, the value built in memory
        assert path.read_bytes() == damaged
        assert any("not a file of the cache" in str(w.message) for w in caught)
        assert disk.entries(tmp_path) == []  # not the cache's: neither listed nor trimmed
    else:
        assert disk.read(tmp_path, only_entry(tmp_path).stem, cache.VERSION) is not None


def test_an_entry_under_another_key_is_not_taken(tmp_path: Path):
    share("one", Builds(0), tmp_path)
    (path,) = disk.entries(tmp_path)
    other = digest((cache.VERSION, "two"))
    path.rename(disk.path_of(tmp_path, other))  # a file renamed: its header names its key
    build = Builds(1)
    table = share("two", build, tmp_path)
    assert build.calls == 1
    assert_same(table, make_table(1))


def test_another_version_reads_nothing(tmp_path: Path):
    share("table", Builds(), tmp_path)
    key = only_entry(tmp_path).stem
    assert disk.read(tmp_path, key, cache.VERSION) is not None
    assert disk.read(tmp_path, key, cache.VERSION + ".post1") is None


def _build_in_a_process(folder: str, log: str, start: float) -> None:
    def slow() -> Table:
        with open(log, "a") as file:
            file.write("built\n")
        time.sleep(0.5)  # the other process asks meanwhile
        return make_table()

    time.sleep(max(0.0, start - time.time()))
    cache.forget()
    table = cache.shared("table", slow, cache.Settings(Path(folder)), CODEC)
    assert np.array_equal(table.values, make_table().values)


def test_two_processes_building_one_entry_at_once(tmp_path: Path):
    folder, log = tmp_path / "cache", tmp_path / "log"
    context = multiprocessing.get_context("fork")
    start = time.time() + 0.5
    workers = [
        context.Process(target=_build_in_a_process, args=(str(folder), str(log), start))
        for _ in range(2)
    ]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(60)
    assert [worker.exitcode for worker in workers] == [0, 0]
    assert log.read_text() == "built\n"  # the second waited for the first and mapped its file
    assert_same(share("table", Builds(), folder), make_table())
    assert not any(p.name.startswith(disk.TEMP_PREFIX) for p in folder.iterdir())


def test_a_writer_replaces_the_file_whole(tmp_path: Path):
    share("table", Builds(0), tmp_path)
    path = only_entry(tmp_path)
    reader = disk.read(tmp_path, path.stem, cache.VERSION)
    assert reader is not None
    entry = CODEC.encode(make_table(1))
    disk.write(tmp_path, path.stem, cache.VERSION, entry)  # e.g. rebuilt by another process
    # the reader's mapping still holds the old file's bytes, whole
    assert np.array_equal(reader.arrays["values"], make_table(0).values)
    again = disk.read(tmp_path, path.stem, cache.VERSION)
    assert again is not None and np.array_equal(again.arrays["values"], make_table(1).values)


def test_the_folder_stays_under_its_size(tmp_path: Path):
    one = only = None
    for seed in range(3):
        share(("table", seed), Builds(seed), tmp_path, max_bytes=int(2.5 * SIZE))
        time.sleep(0.02)
        if seed == 0:
            (one,) = disk.entries(tmp_path)
    files = disk.entries(tmp_path)
    assert len(files) == 2 and one not in files  # the least recently used went first
    assert sum(p.stat().st_size for p in files) <= 2.5 * SIZE
    build = Builds()
    only = share("too large", build, tmp_path, max_bytes=SIZE // 2)  # larger than the cap
    assert_same(only, make_table())
    assert len(disk.entries(tmp_path)) == 2  # kept in memory, not written


def test_max_size_zero_keeps_nothing_on_disk(tmp_path: Path):
    build = Builds()
    share("table", build, tmp_path, max_bytes=0)
    assert not tmp_path.exists() or not any(tmp_path.iterdir())


def test_an_unusable_folder_warns_and_shares_in_memory(tmp_path: Path):
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    with pytest.warns(RuntimeWarning, match="cannot use the cache folder"):
        table = share("table", Builds(), blocker / "cache")
    assert_same(table, make_table())
    assert not table.values.flags.writeable


def test_the_folder_knob_and_its_defaults(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("TINYRACE_CACHE_DIR", str(tmp_path / "variable"))
    assert cache.default_folder() == tmp_path / "variable"
    monkeypatch.delenv("TINYRACE_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.default_folder() == tmp_path / "xdg" / "tinyrace"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache.default_folder() == Path.home() / ".cache" / "tinyrace"
    loaded = load_env_config(None, "circuit", {"cache": {"dir": str(tmp_path / "knob")}})
    settings = cache_settings(loaded.config)
    assert settings.folder == tmp_path / "knob" and settings.max_bytes == 2048 * 2**20


def test_cache_clear_removes_only_cache_files(tmp_path: Path, capsys):
    share("table", Builds(), tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    assert cli.main(["cache", "info", "--dir", str(tmp_path)]) == 0
    assert "1 file(s)" in capsys.readouterr().out
    assert cli.main(["cache", "clear", "--dir", str(tmp_path)]) == 0
    assert "removed 1 cache file(s)" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_no_lock_file_is_left_for_an_entry_not_stored(tmp_path: Path):
    cache.forget()
    small = cache.shared("small", lambda: Table(np.zeros(10), (1, 1), 0.0, np.float32(0)),
                         cache.Settings(tmp_path), CODEC)  # fmt: skip
    assert not small.values.flags.writeable
    assert not tmp_path.exists() or not any(tmp_path.iterdir())
