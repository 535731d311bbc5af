"""Hostile input, seventh round: YAML 1.1's numbers that read otherwise than they look; what
a contributor's walk found (validate names the rules, the reference page, a step's time);
``tinyrace show`` writing its picture as a run's files are written.

PyYAML reads YAML 1.1, where ``1:30`` is the base-60 number 90 and ``010`` the octal 8;
YAML 1.2 (and a reader of the file) takes the first for text and the second for ten. Both are
refused, named at their line with the number YAML would have read. A number YAML reads as
text (``1e3``: 1.1 wants a dot, ``1.0e+3``; or a quoted ``'30'``) is refused as before, now
with what to write instead.
"""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import cv2
import numpy as np
import pytest

from tinyrace.config import ConfigError
from tinyrace.config.load import load_env_config
from tinyrace.config.yaml_file import parse_yaml
from tinyrace.examples import TRACKS_DIR
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


# -- a contributor's walk: what validate says of the rules, the reference page ---------------


@pytest.mark.parametrize(
    ("design", "rewards"),
    [
        ("", "rewards: out_of_bounds, time, tiles; ends: out_of_bounds, lap_finished"),
        ("reward_design: {time_penalty: 0}\n", "rewards: out_of_bounds, tiles; ends:"),
        (
            "reward_design: {off_road_penalty: 0.5}\n",
            "rewards: out_of_bounds, time, tiles, off_road;",
        ),
    ],
)
def test_validate_names_the_reward_terms_that_can_pay_and_the_ends(
    tmp_path: Path, design: str, rewards: str
) -> None:
    config = tmp_path / "track.yaml"
    config.write_text("track: {type: procedural}\n" + design)
    problems, summary = validate_path(config)
    assert problems == [] and f"; {rewards}" in summary, summary
    assert summary.index("rewards:") < summary.index("observes:")


def test_the_reference_generator_writes_a_new_page_and_refuses_one_without_markers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from tinyrace.config.reference import END, START, main

    page = tmp_path / "parts.md"
    assert main([str(page)]) == 0
    text = page.read_text()
    assert START in text and END in text and "## `track.yaml`" in text
    other = tmp_path / "notes.md"
    other.write_text("my notes\n")
    assert main([str(other)]) == 1
    assert other.read_text() == "my notes\n"
    assert "has no reference markers" in capsys.readouterr().err
    assert main([str(tmp_path / "missing" / "ref.md")]) == 1
    assert "No such file or directory" in capsys.readouterr().err


@pytest.mark.parametrize(("environment", "fps"), [(None, 50.0), ("formula_student", 30.0)])
def test_a_steps_facts_carry_its_sim_time(environment: str | None, fps: float) -> None:
    """A rule part "per second" scales by ``facts.dt``: 1 / sim.fps, whatever the track."""
    import gymnasium as gym

    keys = {} if environment is None else {"environment": environment}
    env = gym.make("tinyrace/TinyRace-v0", **keys)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    core = env.unwrapped
    assert core.config.sim.fps == fps
    assert [facts.dt for facts in core.episode.facts] == [1.0 / fps]
    env.close()


# -- tinyrace show writes its picture as a run's files are written ---------------------------


def _show(output: Path, *more: str) -> int:
    from tinyrace import cli

    return cli.main(["show", "formula_student", "-o", str(output), *more])


def test_show_writes_a_name_that_is_not_utf8(tmp_path: Path) -> None:
    """OpenCV's writer crashed the interpreter (a segmentation fault) on such a name."""
    output = Path(os.fsdecode(bytes(tmp_path) + b"/caf\xe9.png"))
    assert _show(output) == 0
    (written,) = os.listdir(bytes(tmp_path))
    assert written == b"caf\xe9.png"
    assert cv2.imdecode(np.fromfile(output, np.uint8), cv2.IMREAD_COLOR).shape[1] == 1600


def test_show_never_writes_over_an_input_by_another_name(tmp_path: Path) -> None:
    track = tmp_path / "fs"
    shutil.copytree(TRACKS_DIR / "formula_student", track)
    picture = track / "formula_student.png"
    before = picture.read_bytes()
    (tmp_path / "hard.png").hardlink_to(picture)
    from tinyrace import cli

    code = cli.main(["show", str(track), "-o", str(tmp_path / "hard.png"), "--force"])
    assert code == 2 and picture.read_bytes() == before


@pytest.mark.parametrize("kind", ["fifo", "link_to_file", "link_to_device"])
def test_show_refuses_a_fifo_or_a_link_and_leaves_it(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    output = tmp_path / "out.png"
    notes = tmp_path / "notes.txt"
    notes.write_text("notes\n")
    if kind == "fifo":
        os.mkfifo(output)  # OpenCV's writer blocked on it forever
    elif kind == "link_to_file":
        output.symlink_to(notes)  # OpenCV's writer wrote the picture into notes.txt
    else:
        output.symlink_to("/dev/full")  # a failed write removed the link
    assert _show(output, "--force") == 2
    assert "-o/--output" in capsys.readouterr().err
    assert notes.read_text() == "notes\n"
    assert output.is_symlink() or stat.S_ISFIFO(os.lstat(output).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "out.png"]  # no temp


def test_show_replaces_a_file_of_its_own_whole(tmp_path: Path) -> None:
    output = tmp_path / "out.jpg"
    output.write_bytes(b"old")
    assert _show(output, "--force") == 0
    assert output.read_bytes()[:3] == b"\xff\xd8\xff"  # a JPEG, as the name says
    assert [p.name for p in tmp_path.iterdir()] == ["out.jpg"]
