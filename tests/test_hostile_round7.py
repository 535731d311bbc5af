"""Hostile input, seventh round: YAML 1.1's numbers that read otherwise than they look.

PyYAML reads YAML 1.1, where ``1:30`` is the base-60 number 90 and ``010`` the octal 8;
YAML 1.2 (and a reader of the file) takes the first for text and the second for ten. Both are
refused, named at their line with the number YAML would have read. A number YAML reads as
text (``1e3``: 1.1 wants a dot, ``1.0e+3``; or a quoted ``'30'``) is refused as before, now
with what to write instead.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tinyrace.config import ConfigError
from tinyrace.config.load import load_env_config
from tinyrace.config.yaml_file import parse_yaml
from tinyrace.validate import validate_path


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("episodes: 1:30", "1:30 is YAML 1.1's base-60 number 90: write 90, or quote it"),
        ("a: 12:30:00", "base-60 number 45000: write 45000"),
        ("a: -1:30", "base-60 number -90: write -90"),
        ("a: 1:30.5", "base-60 number 90.5: write 90.5"),
        ("a: [0, 1:30]", "base-60 number 90"),
        ("seed: 010", "010 is YAML 1.1's octal number 8: write 10 without the leading zero"),
        ("a: -0_10", "octal number -8: write -10"),
        ("a: +017", "octal number 15: write 17"),
    ],
)
def test_yaml11_numbers_that_read_otherwise_are_refused_at_their_line(text: str, said: str) -> None:
    with pytest.raises(ConfigError) as error:
        parse_yaml("# a comment\n" + text + "\n", "exp.yaml")
    (problem,) = error.value.problems
    assert (problem.source, problem.path, problem.value) == ("exp.yaml", "line 2", text)
    assert said in problem.allowed


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("a: '1:30'", "1:30"),  # quoted: text, as written
        ('a: "010"', "010"),
        ("a: 0", 0),
        ("a: 00", 0),  # octal and decimal agree
        ("a: 07", 7),
        ("a: 010.5", 10.5),  # a float with a leading zero is decimal in YAML 1.1 too
        ("a: 0x1F", 31),
        ("a: 1_000", 1000),
        ("a: 08", "08"),  # not octal, so YAML 1.1 reads text; the schema names it
        ("a: 1:3_0", "1:3_0"),
        ("a: 12:34:56abc", "12:34:56abc"),
    ],
)
def test_numbers_that_read_as_they_look_are_kept(text: str, value: object) -> None:
    assert parse_yaml(text, "x.yaml") == {"a": value}


def test_a_base60_value_in_an_experiment_is_named_by_validate(tmp_path: Path) -> None:
    experiment = tmp_path / "exp.yaml"
    experiment.write_text("env: {environment: carracing}\nepisodes: 1:30\n")
    before = experiment.read_bytes()
    problems, summary = validate_path(experiment)
    assert summary == ""
    assert any("line 2" in line and "base-60 number 90" in line for line in problems), problems
    assert experiment.read_bytes() == before


@pytest.mark.parametrize(
    ("written", "hint"),
    [
        ("1e3", "('1e3' is text in YAML: write 1000, unquoted)"),
        ("'30'", "('30' is text in YAML: write 30, unquoted)"),
        ("25e-2", "('25e-2' is text in YAML: write 0.25, unquoted)"),
    ],
)
def test_a_number_yaml_reads_as_text_is_named_with_what_to_write(
    tmp_path: Path, written: str, hint: str
) -> None:
    config = tmp_path / "track.yaml"
    config.write_text(f"track: {{type: procedural}}\ncar: {{velocity: {written}}}\n")
    with pytest.raises(ConfigError) as error:
        load_env_config(config)
    (problem,) = error.value.problems
    assert problem.path == "car.velocity"
    assert problem.allowed.endswith(hint), problem.allowed


@pytest.mark.parametrize("written", ["fast", "'nan'", "inf", "'1e999'"])
def test_text_that_is_no_finite_number_gets_no_hint(tmp_path: Path, written: str) -> None:
    config = tmp_path / "track.yaml"
    config.write_text(f"track: {{type: procedural}}\ncar: {{velocity: {written}}}\n")
    with pytest.raises(ConfigError) as error:
        load_env_config(config)
    assert "is text in YAML" not in error.value.problems[0].allowed


def test_a_name_yaml_reads_as_a_boolean_is_named_with_the_quote_to_add(tmp_path: Path) -> None:
    config = tmp_path / "track.yaml"
    config.write_text("track: {type: procedural}\ncameras: [{id: no}]\n")
    with pytest.raises(ConfigError) as error:
        load_env_config(config)
    (problem,) = error.value.problems
    assert (problem.path, problem.value) == ("cameras[0].id", False)
    assert "YAML reads yes, no, on, off, true and false as booleans: quote it" in problem.allowed
