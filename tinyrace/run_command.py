"""``tinyrace run``: the experiment or track to run, the command line's overrides of it
(``--episodes``, ``--seed``, ``--no-video``, ``--model``) and its run folders' place
(``--out``), each checked before any episode."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tinyrace.errors import ConfigError, Problem, UsageError, cut_middle

if TYPE_CHECKING:
    from tinyrace.experiment import Experiment, RunResult
    from tinyrace.experiment.race_runner import RaceRunResult


def default_experiment() -> Path:
    """The shipped CarRacing experiment (package data, found from any folder)."""
    from tinyrace.examples import DEFAULT_EXPERIMENT

    return DEFAULT_EXPERIMENT


def run(args: argparse.Namespace) -> int:
    """``tinyrace run``: the experiment (or track) run, its report printed; the exit code."""
    from tinyrace.experiment import print_report, run_experiment
    from tinyrace.experiment.target import load_target

    target = args.experiment if args.experiment is not None else default_experiment()
    experiment, track = load_target(target, "NAME_OR_PATH")
    experiment = _overridden(experiment, args)
    out = _out_folder(args.out, experiment.config.output.dir, args.force)
    config = experiment.config
    if not (args.quiet or args.json):
        episodes = f"{config.episodes} episode{'s' if config.episodes != 1 else ''}"
        what = f"{episodes}, driver {config.driver}"
        if experiment.is_race:
            what = f"{episodes}, a race of {len(experiment.agents)} cars"
        kind = "the track " if track else ""
        print(f"tinyrace: running {kind}{experiment.source} ({what})")
    try:
        result = run_experiment(experiment, out, show_progress=not args.quiet)
    except ConfigError as exc:  # --model's driver: named as the command line gave it
        if args.model is None:
            raise
        raise ConfigError([_from_model(p, args.model) for p in exc.problems]) from None
    if args.json:
        print(json.dumps(_json_summary(result), indent=2))
    elif not args.quiet:
        print_report(result)
    if result.interrupted is None:
        return 0
    done = len(result.episodes)
    print(
        f"tinyrace: interrupted; {done} finished episode(s) written to {result.run_dir}",
        file=sys.stderr,
    )
    return 128 + result.interrupted


def _overridden(experiment: Experiment, args: argparse.Namespace) -> Experiment:
    """The experiment with the command line's --episodes, --seed, --no-video and --model."""
    config = experiment.config
    if args.episodes is not None:
        config = dataclasses.replace(config, episodes=args.episodes)
    if args.seed is not None:
        config = dataclasses.replace(config, seed=args.seed)
    if args.no_video:
        config = dataclasses.replace(config, output=dataclasses.replace(config.output, video=False))
    if args.model is not None:
        config = dataclasses.replace(
            config, driver=MODEL_DRIVER, driver_args={"model": _model(args.model, experiment)}
        )
    return dataclasses.replace(experiment, config=config)


MODEL_DRIVER = "tinyrace.sb3:ModelDriver"  # --model's driver


def _from_model(problem: Problem, model: str) -> Problem:
    """A problem of the driver that ``--model`` chose, named as the command line's."""
    if problem.path != "driver" and not problem.path.startswith("driver_args."):
        return problem
    return Problem("<command line>", "--model", model, problem.allowed)


def _model(name: str, experiment: Experiment) -> str:
    """``--model`` checked: one car's run, a file, and Stable-Baselines3 importable."""
    from tinyrace.train import missing

    if experiment.is_race:
        raise UsageError(
            f"argument --model: a race's cars have drivers of their own: give each car "
            f"driver: {MODEL_DRIVER} with driver_args: {{model: ...}} in drivers.<car>"
        )
    try:
        found = Path(name).is_file()
    except (OSError, ValueError):
        found = False
    if not found:
        raise UsageError(f"argument --model: got {cut_middle(name)!r}; expected a saved model file")
    lacking = missing("a model's driver")
    if lacking:
        raise UsageError(f"argument --model: {lacking}")
    return name


def _out_folder(out: str | None, default: str, force: bool) -> Path | None:
    """``--out`` checked: a folder, and (unless ``force``) not inside a track folder nor
    the installed package (``shipped_holding``, as ``tinyrace examples copy`` refuses)."""
    from tinyrace.examples import shipped_holding
    from tinyrace.experiment.files import unmakeable
    from tinyrace.validate import system_reason, track_folder_holding

    path = Path(out if out is not None else default)
    where = "argument -o/--out" if out is not None else "output.dir (run folders)"
    try:
        if path.exists() and not path.is_dir():
            raise UsageError(f"{where}: {cut_middle(str(path))!r} is a file; expected a folder")
        inside = track_folder_holding(path.resolve())
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte
        raise UsageError(
            f"{where}: {cut_middle(str(path))!r} is no folder the system can make "
            f"({system_reason(exc)})"
        ) from None
    unmade = unmakeable(path / "probe")  # the run folders go inside it
    if unmade is not None:
        raise UsageError(f"{where}: {cut_middle(str(path))!r}: {unmade}")
    if inside is not None and not force:
        raise UsageError(
            f"{where}: {str(path)!r} lies inside the track folder {str(inside)!r}; "
            "expected a folder outside it (run elsewhere, give -o, or --force)"
        )
    shipped = shipped_holding(path)
    if shipped is not None and not force:
        raise UsageError(
            f"{where}: {str(path)!r} lies inside the installed package {str(shipped)!r}; "
            "expected a folder outside it (run elsewhere, give -o, or --force)"
        )
    return None if out is None else path


def _json_summary(result: RunResult | RaceRunResult) -> dict[str, Any]:
    from dataclasses import asdict

    return {
        "run_dir": str(result.run_dir),
        "interrupted": result.interrupted is not None,
        "episodes": [asdict(e) for e in result.episodes],
        "summary": result.summary,
    }
