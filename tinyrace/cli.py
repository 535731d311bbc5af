"""The tinyrace command: run experiments, validate configs, picture tracks, drive by hand."""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from tinyrace import run_command
from tinyrace.errors import ConfigError, Problem, UsageError, cut_middle, one_line
from tinyrace.examples import find_example


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``tinyrace: error: ...``), exit 2."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def main(argv: list[str] | None = None) -> int:
    """Exit codes: 0 done; 1 problems found (validate) or an internal error; 2 a user error
    (bad argument, configuration, driver); 130 / 143 a run stopped by SIGINT / SIGTERM."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        return _user_error(str(exc))
    if args.command is None:
        parser.print_help()
        return 2
    try:
        code: int = args.handler(args)
        return code
    except (ConfigError, UsageError) as exc:
        if args.debug:
            raise
        return _user_error(_one_line(exc))
    except KeyboardInterrupt:
        print("tinyrace: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:  # a path the system refuses: too long, no permission, a full disk
        if args.debug:
            raise
        from tinyrace.validate import system_reason

        name = cut_middle(str(exc.filename)) if exc.filename is not None else "a path"
        return _user_error(f"{name!r}: the system refuses it ({system_reason(exc)})")
    except Exception as exc:
        if args.debug:
            raise
        text = cut_middle(f"{type(exc).__name__}: {exc}", 2000)
        print(f"tinyrace: internal error: {text} (--debug shows where)", file=sys.stderr)
        return 1


def _user_error(message: str) -> int:
    print(f"tinyrace: error: {message}", file=sys.stderr)
    return 2


def _one_line(exc: Exception) -> str:
    if isinstance(exc, ConfigError):
        problems = [str(p) for p in exc.problems]
        head = "" if len(problems) == 1 else f"{len(problems)} problems: "
        return head + "; ".join(problems)
    return " ".join(str(exc).split())


def _count(low: int, what: str, high: int | None = None) -> Callable[[str], int]:
    """An argparse type: a whole number from ``low`` (to ``high``)."""

    def parse(text: str) -> int:
        # ASCII digits only: int() also reads 1_0 as 10 and other scripts' digits (١)
        digits = text.strip()
        value = int(digits) if len(digits) <= 40 and re.fullmatch(r"[+-]?[0-9]+", digits) else None
        if value is None or value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"got {cut_middle(text)!r}; expected {what}")
        return value

    return parse


def _parser() -> argparse.ArgumentParser:
    from tinyrace import __version__
    from tinyrace.config.bounds import MAX_EPISODES, MAX_SEED

    parser = _Parser(prog="tinyrace", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tinyrace {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    commands = parser.add_subparsers(dest="command")
    run = commands.add_parser(
        "run",
        help="run an experiment, or a track with the default driver (default: carracing)",
    )
    run.add_argument(
        "experiment",
        nargs="?",
        metavar="NAME_OR_PATH",
        help="an experiment file, a track folder or track.yaml, or a shipped name",
    )
    run.add_argument(
        "-o", "--out", help="folder for run folders (overrides output.dir; default: ./runs)"
    )
    run.add_argument(
        "--episodes",
        type=_count(1, f"a whole number from 1 to {MAX_EPISODES:,}", MAX_EPISODES),
        help="override the episodes",
    )
    run.add_argument(
        "--seed",
        type=_count(0, f"a whole number from 0 to {MAX_SEED}", MAX_SEED),
        help="override the first seed",
    )
    run.add_argument(
        "--model",
        metavar="FILE.zip",
        help="drive with a saved Stable-Baselines3 model, e.g. tinyrace train's (the driver "
        "tinyrace.sb3:ModelDriver; needs the train extra)",
    )
    run.add_argument("--no-video", action="store_true", help="write no videos")
    run.add_argument("--force", action="store_true", help="allow run folders inside a track folder")
    run.add_argument("--quiet", action="store_true", help="print nothing but errors")
    run.add_argument("--json", action="store_true", help="print the results summary as JSON")
    run.set_defaults(handler=run_command.run)
    report = commands.add_parser("report", help="rebuild report.html of a run folder")
    report.add_argument("run_dir", help="a run folder (holding results.json and episodes.csv)")
    report.set_defaults(handler=_report)
    validate = commands.add_parser(
        "validate", help="check a track folder, track.yaml or experiment"
    )
    validate.add_argument("path", help="a path, or a shipped config's or track's name")
    validate.set_defaults(handler=_validate)
    show = commands.add_parser("show", help="save a picture of a track")
    show.add_argument(
        "path", help="track folder, track.yaml, experiment, a shipped name, or 'procedural'"
    )
    show.add_argument(
        "--seed",
        type=_count(0, "a whole number >= 0"),
        default=None,
        help="procedural tracks: which seed's track (default 0; other tracks have one picture)",
    )
    show.add_argument("-o", "--output", help="PNG file (default: <name>.png in this folder)")
    show.add_argument(
        "--force",
        action="store_true",
        help="replace an existing file or write into a track folder (never over an input)",
    )
    show.set_defaults(handler=_show)
    play = commands.add_parser("play", help="drive with the keyboard in a window")
    play.add_argument(
        "path", nargs="?", help="track folder, track.yaml or experiment (default: procedural)"
    )
    play.add_argument("--seed", type=_count(0, "a whole number >= 0"), default=None)
    play.set_defaults(handler=_play)
    _examples_parser(commands)
    _cache_parser(commands)
    _train_parser(commands)
    for command in commands.choices.values():  # also after the command: tinyrace run --debug
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)
    return parser


def _examples_parser(commands: argparse._SubParsersAction[_Parser]) -> None:
    examples = commands.add_parser(
        "examples", help="list the shipped tracks and configs; copy one out to edit"
    )
    examples.set_defaults(handler=_examples)
    actions = examples.add_subparsers(dest="action")
    copy = actions.add_parser("copy", help="copy a shipped track and/or config (never overwrites)")
    copy.add_argument("name", help="a name from `tinyrace examples`")
    copy.add_argument("dir", nargs="?", default=".", help="where to copy it (default: here)")


def _cache_parser(commands: argparse._SubParsersAction[_Parser]) -> None:
    cache = commands.add_parser(
        "cache", help="show (info) or empty (clear) the folder of shared track data"
    )
    cache.add_argument("action", nargs="?", choices=("info", "clear"), default="info")
    cache.add_argument(
        "--dir",
        help="the cache folder (default: $TINYRACE_CACHE_DIR, else $XDG_CACHE_HOME/tinyrace, "
        "else ~/.cache/tinyrace; a config's cache.dir names another)",
    )
    cache.set_defaults(handler=_cache)


def _train_parser(commands: argparse._SubParsersAction[_Parser]) -> None:
    from tinyrace.train import add_arguments

    train = commands.add_parser(
        "train",
        help="train PPO (Stable-Baselines3) on an env; needs the train extra",
    )
    add_arguments(train, _count)
    train.set_defaults(handler=_train)


# -- train -------------------------------------------------------------------------------------
def _train(args: argparse.Namespace) -> int:
    from tinyrace import train

    return train.run_command(args)


# -- report ------------------------------------------------------------------------------------
def _report(args: argparse.Namespace) -> int:
    from tinyrace.experiment import rebuild_report

    run_dir = Path(args.run_dir)
    if not (_is_file(run_dir / "results.json") and _is_file(run_dir / "episodes.csv")):
        raise UsageError(
            f"argument run_dir: {args.run_dir!r} is no run folder "
            "(expected a folder holding results.json and episodes.csv)"
        )
    try:
        path = rebuild_report(run_dir)  # a ConfigError names the file and field
    except ConfigError:
        raise
    except (ValueError, KeyError, TypeError) as exc:  # results.json or episodes.csv edited
        raise UsageError(
            f"argument run_dir: cannot read the run in {args.run_dir!r} ({one_line(exc)})"
        ) from exc
    print(f"wrote {path}")
    return 0


def _is_file(path: Path) -> bool:
    """``Path.is_file``, but False for names the system refuses (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


# -- examples ----------------------------------------------------------------------------------
def _examples(args: argparse.Namespace) -> int:
    from tinyrace.examples import copy_example, examples

    if args.action == "copy":
        for target in copy_example(args.name, Path(args.dir)):
            print(f"copied {args.name} to {target}")
        return 0
    shown = examples()
    width = max(len(e.name) for e in shown)
    for example in shown:
        print(f"{example.kind:<6}  {example.name:<{width}}  {example.summary}")
    print("run one: tinyrace run NAME; copy one out to edit: tinyrace examples copy NAME [DIR]")
    return 0


# -- cache -------------------------------------------------------------------------------------
def _cache(args: argparse.Namespace) -> int:
    from tinyrace.cache import command

    print("\n".join(command.clear(args.dir) if args.action == "clear" else command.info(args.dir)))
    return 0


# -- validate ----------------------------------------------------------------------------------
def _validate(args: argparse.Namespace) -> int:
    from tinyrace.errors import problem_count
    from tinyrace.validate import validate_problems

    path = find_example(args.path)  # the file checked, named in the answer
    problems, summary = validate_problems(path)
    for problem in problems:
        print(problem)
    if problems:
        print(f"{problem_count(problems):,} problem(s) found", file=sys.stderr)
        return 1
    print(f"OK: {path}: {summary}")
    return 0


# -- show --------------------------------------------------------------------------------------
def _show(args: argparse.Namespace) -> int:
    import cv2

    from tinyrace.validate import check_output, picture, system_reason, write_picture

    if args.output is not None and not args.output.strip():  # -o '': no file name
        allowed = "expected a PNG file's path (leave -o out for <name>.png in this folder)"
        raise ConfigError(Problem("<command line>", "-o/--output", args.output, allowed))
    target = args.path if args.path == "procedural" else str(find_example(args.path))
    shown = picture(target, 0 if args.seed is None else args.seed)
    if args.seed is not None and not shown.seeded:  # the same picture for every seed
        print(
            f"tinyrace: note: --seed {args.seed} is ignored: only a procedural track's picture "
            "depends on the seed",
            file=sys.stderr,
        )
    image = shown.image
    output = Path(args.output or f"{shown.name}.png")
    check_output(output, shown.inputs, args.force)
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        allowed = f"a path whose folder can be made ({system_reason(exc)})"
        raise ConfigError(Problem("<command line>", "-o/--output", str(output), allowed)) from None
    encoded, data = cv2.imencode(output.suffix.lower(), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    assert encoded, output.suffix  # check_output allows the suffixes OpenCV encodes
    write_picture(output, data.tobytes())
    print(f"wrote {output} ({image.shape[1]}x{image.shape[0]})")
    return 0


# -- play --------------------------------------------------------------------------------------
def _play(args: argparse.Namespace) -> int:
    missing = _play_missing()
    if missing:
        print(f"tinyrace play needs {missing}", file=sys.stderr)
        return 2
    from tinyrace.play import play

    return play(args.path and str(find_example(args.path)), args.seed)


def _play_missing() -> str | None:
    """What keyboard driving lacks here: a display or pygame (None when both are there)."""
    try:
        import pygame  # noqa: F401
    except ImportError:
        from tinyrace import __version__

        return (
            'pygame: pip install ".[human]" (from a clone; from a wheel: pip install '
            f'"path/to/tinyrace-{__version__}-py3-none-any.whl[human]"; or pip install pygame-ce)'
        )
    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if (
        sys.platform.startswith("linux")
        and headless
        and os.environ.get("SDL_VIDEODRIVER") != "dummy"
    ):
        return "a display (no DISPLAY or WAYLAND_DISPLAY is set; run it on a desktop session)"
    return None


if __name__ == "__main__":  # python -m tinyrace.cli, as python -m tinyrace
    raise SystemExit(main())
