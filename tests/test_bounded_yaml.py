"""Issue 12.3, YAML: bombs, deep nesting, duplicate keys, special and huge files are refused
with a ConfigError naming the file, before they are read whole or built into objects."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import gymnasium as gym
import pytest

import tinyrace  # noqa: F401 (registers the ids)
from tinyrace import cli
from tinyrace.config.yaml_file import MAX_DEPTH, MAX_VALUES, MAX_YAML_BYTES, read_yaml
from tinyrace.errors import ConfigError

LEVELS = "abcdefghi"  # each level lists the one before ten times: 10**9 values expanded
BOMB = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{b}: &{b} [{', '.join([f'*{a}'] * 10)}]\n" for a, b in itertools.pairwise(LEVELS)
)


def _error(path: Path) -> str:
    with pytest.raises(ConfigError) as caught:
        read_yaml(path)
    text = str(caught.value)
    assert str(path) in text
    assert len(text) < 600  # the value is quoted shortened, never whole
    return text


def test_an_alias_bomb_is_refused_before_it_expands(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text(BOMB)
    assert f"more than {MAX_VALUES:,} values" in _error(path)


def test_a_recursive_alias_is_refused(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text("sim: &loop {a: *loop}\n")
    assert "inside its own anchor" in _error(path)


@pytest.mark.parametrize("depth", [MAX_DEPTH + 1, 100_000])
def test_nesting_beyond_the_limit_is_refused(tmp_path: Path, depth: int):
    path = tmp_path / "track.yaml"
    path.write_text("[" * depth + "]" * depth)
    assert f"nesting deeper than {MAX_DEPTH} levels" in _error(path)


def test_nesting_through_an_alias_counts_its_expansion(tmp_path: Path):
    deep = "[" * 20 + "1" + "]" * 20
    path = tmp_path / "track.yaml"
    path.write_text(f"a: &deep {deep}\nb: {'[' * 20}*deep{']' * 20}\n")
    assert "alias *deep expanded" in _error(path)


def test_nesting_at_the_limit_is_read(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text("[" * MAX_DEPTH + "]" * MAX_DEPTH)
    assert read_yaml(path) is not None


def test_a_duplicate_key_names_both_lines(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text("sim:\n  fps: 30\ncar: {}\nsim:\n  fps: 60\n")
    text = _error(path)
    assert "'sim' is given twice" in text and "lines 1 and 4" in text


def test_a_merge_key_is_not_a_duplicate(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text("base: &b {fps: 30}\nsim: {<<: *b, fps: 60}\n")
    assert read_yaml(path)["sim"] == {"fps": 60}


def test_an_oversize_file_is_refused_by_its_size(tmp_path: Path):
    path = tmp_path / "track.yaml"
    path.write_text("#" * MAX_YAML_BYTES + "\n")
    assert f"at most {MAX_YAML_BYTES:,} bytes" in _error(path)


def test_a_fifo_is_refused_without_blocking(tmp_path: Path):
    path = tmp_path / "track.yaml"
    os.mkfifo(path)  # nobody writes: reading it would block for ever
    assert "not a FIFO" in _error(path)


@pytest.mark.parametrize("path", ["/dev/zero", "/dev/urandom"])
def test_a_device_is_refused(path: str):
    if not Path(path).exists():
        pytest.fail(f"{path} is expected on the Linux CI machine")
    assert "character device" in _error(Path(path))


def test_a_folder_named_like_a_file_is_refused(tmp_path: Path):
    (tmp_path / "x.yaml").mkdir()
    assert "not a folder" in _error(tmp_path / "x.yaml")


@pytest.mark.parametrize(
    "text, expected",
    [
        ("\x00\x01\x02\xff\xfe binary", "UTF-8"),
        ("when: 2001-13-45\n", "month must be in 1..12"),
        ("n: " + "9" * 5000 + "\n", "cannot be read"),
        ("a: [1, 2\n", "invalid YAML"),
        ("--- 1\n--- 2\n", "invalid YAML"),
    ],
)
def test_unreadable_text_is_a_config_error(tmp_path: Path, text: str, expected: str):
    path = tmp_path / "track.yaml"
    path.write_bytes(text.encode("latin-1"))
    assert expected in _error(path)


def test_gym_make_and_validate_refuse_a_bomb_the_same_way(tmp_path: Path, capsys):
    (tmp_path / "track.yaml").write_text(BOMB)
    with pytest.raises(ConfigError, match="aliases expanded"):
        gym.make("tinyrace/TinyRace-v0", environment=str(tmp_path))
    assert cli.main(["validate", str(tmp_path)]) != 0
    assert "aliases expanded" in capsys.readouterr().out


def test_a_huge_integer_is_quoted_short(tmp_path: Path):
    (tmp_path / "track.yaml").write_text("sim: {step_limit: " + "9" * 4000 + "}\n")
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", config=str(tmp_path / "track.yaml"))
    assert "sim.step_limit" in str(caught.value) and len(str(caught.value)) < 400


def test_the_documented_bounds_are_the_enforced_ones():
    from tinyrace.config.schema import MAX_CAMERA_PIXELS, MAX_FRAME_PIXELS, FilesConfig

    doc = " ".join(FilesConfig.__doc__.split())
    assert f"at most {MAX_YAML_BYTES >> 20} MiB" in doc
    assert f"nests at most {MAX_DEPTH} levels" in doc
    assert f"at most {MAX_VALUES:,} values" in doc
    assert f"at most {MAX_FRAME_PIXELS >> 20} Mpx" in doc
    assert MAX_CAMERA_PIXELS == 4096 * 4096 and "4096 x 4096 px" in doc
