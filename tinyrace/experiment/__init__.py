"""YAML experiments: an env, a driver, episodes; run end to end by ``tinyrace run``."""

from tinyrace.config.experiment import ExperimentConfig, OutputConfig
from tinyrace.experiment.load import (
    Experiment,
    experiment_from_dict,
    is_experiment,
    load_experiment,
)
from tinyrace.experiment.rebuild import rebuild_report
from tinyrace.experiment.report import write_report
from tinyrace.experiment.runner import RunResult, print_report, run_experiment

__all__ = [
    "Experiment",
    "ExperimentConfig",
    "OutputConfig",
    "RunResult",
    "experiment_from_dict",
    "is_experiment",
    "load_experiment",
    "print_report",
    "rebuild_report",
    "run_experiment",
    "write_report",
]
