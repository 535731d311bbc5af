"""The ``tinyrace`` command: run experiments, validate configs, picture tracks, drive by hand."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from tinyrace.errors import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.handler(args)
    except ConfigError as exc:
        print(f"tinyrace: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\ntinyrace: interrupted", file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tinyrace", description=__doc__)
    commands = parser.add_subparsers(dest="command")
    run = commands.add_parser(
        "run", help="run an experiment file (default: configs/carracing.yaml)"
    )
    run.add_argument("experiment", nargs="?", help="experiment YAML")
    run.add_argument("--out", help="directory for run directories (overrides output.dir)")
    run.add_argument("--episodes", type=int, help="override the number of episodes")
    run.add_argument("--no-video", action="store_true", help="write no videos")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(handler=_run)
    validate = commands.add_parser(
        "validate", help="check a track folder, track.yaml or experiment"
    )
    validate.add_argument("path")
    validate.set_defaults(handler=_validate)
    show = commands.add_parser("show", help="save a picture of a track")
    show.add_argument("path", help="track folder, track.yaml, experiment, or 'procedural'")
    show.add_argument("--seed", type=int, default=0, help="procedural tracks: which seed's track")
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
    play.add_argument("--seed", type=int, default=None)
    play.set_defaults(handler=_play)
    return parser


# -- run ---------------------------------------------------------------------------------------
def default_experiment() -> Path:
    """The shipped CarRacing experiment (package data, found from any folder)."""
    from tinyrace.examples import DEFAULT_EXPERIMENT

    return DEFAULT_EXPERIMENT


def _run(args: argparse.Namespace) -> int:
    import dataclasses

    from tinyrace.experiment import (
        experiment_from_dict,
        load_experiment,
        print_report,
        run_experiment,
    )

    path = Path(args.experiment) if args.experiment else default_experiment()
    if path is None:
        print(
            "tinyrace: no configs/carracing.yaml here; running the built-in CarRacing experiment",
            file=sys.stderr,
        )
        experiment = experiment_from_dict({}, "carracing", Path.cwd())
    else:
        experiment = load_experiment(path)
    config = experiment.config
    if args.episodes is not None:
        config = dataclasses.replace(config, episodes=max(1, args.episodes))
    if args.no_video:
        config = dataclasses.replace(config, output=dataclasses.replace(config.output, video=False))
    experiment = dataclasses.replace(experiment, config=config)
    what = f"{config.episodes} episodes, driver {config.driver}"
    print(f"tinyrace: running {experiment.source} ({what})")
    result = run_experiment(
        experiment, Path(args.out) if args.out else None, show_progress=not args.quiet
    )
    print_report(result)
    return 0


# -- validate ----------------------------------------------------------------------------------
def _validate(args: argparse.Namespace) -> int:
    from tinyrace.validate import validate_path

    problems, summary = validate_path(Path(args.path))
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} problem(s) found", file=sys.stderr)
        return 1
    print(f"OK: {summary}")
    return 0


# -- show --------------------------------------------------------------------------------------
def _show(args: argparse.Namespace) -> int:
    import cv2

    from tinyrace.validate import check_output, picture

    shown = picture(args.path, args.seed)
    image = shown.image
    output = Path(args.output or f"{shown.name}.png")
    check_output(output, shown.inputs, args.force)
    output.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(output), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        print(f"tinyrace: could not write {output} (use a .png path)", file=sys.stderr)
        return 1
    print(f"wrote {output} ({image.shape[1]}x{image.shape[0]})")
    return 0


# -- play --------------------------------------------------------------------------------------
def _play(args: argparse.Namespace) -> int:
    missing = _play_missing()
    if missing:
        print(f"tinyrace play needs {missing}", file=sys.stderr)
        return 2
    from tinyrace.play import play

    return play(args.path, args.seed)


def _play_missing() -> str | None:
    """What keyboard driving lacks here: a display or pygame (None when both are there)."""
    try:
        import pygame  # noqa: F401
    except ImportError:
        return 'pygame: pip install "tinyrace[human]"'
    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if (
        sys.platform.startswith("linux")
        and headless
        and os.environ.get("SDL_VIDEODRIVER") != "dummy"
    ):
        return "a display (no DISPLAY or WAYLAND_DISPLAY is set; run it on a desktop session)"
    return None
