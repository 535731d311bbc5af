"""A long-lived worker of the hostile-input campaign (tests/test_hostile_campaign.py).

Run as ``python hostile_worker.py MEMORY_BYTES SECONDS``: it limits its address space, then
reads cases (length-prefixed pickles) from stdin and answers each with an outcome, each case
within SECONDS of the process's CPU time (ITIMER_PROF: a busy loop, whatever the machine's
load) and WALL_FACTOR times that of wall time (SIGALRM: a case blocked on a lock or a read).
Library output to stdout is sent to /dev/null; answers go to a copy of the original stdout.
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
import resource
import signal
import struct
import sys
import traceback
from pathlib import Path
from typing import Any, BinaryIO

WALL_FACTOR = 3  # a case's wall-time bound over its CPU-time bound: room for a loaded machine


class CaseTimeout(BaseException):
    """The case ran past its alarm (a BaseException: code under test must not swallow it)."""


def _alarm(signum: int, frame: Any) -> None:
    raise CaseTimeout()


def _problems(exc: Exception) -> list[tuple[str, str, str]]:
    return [(p.source, p.path, str(p)) for p in exc.problems]


def config_case(folder: str) -> dict[str, Any]:
    """validate the folder, then gym.make + reset + step it: both must agree."""
    import gymnasium as gym

    from tinyrace.errors import ConfigError
    from tinyrace.validate import neutral_action, validate_path

    problems, _ = validate_path(Path(folder))
    try:
        env = gym.make("tinyrace/TinyRace-v0", environment=folder, render_mode="rgb_array")
        try:
            env.reset(seed=0)
            env.step(neutral_action(env.action_space))
            frame = env.render()
            assert frame.size <= 32 << 22  # (32 Mpx x 3 channels) a capped overview
        finally:
            env.close()
    except ConfigError as exc:
        return {"outcome": "config_error", "validate": problems, "make": _problems(exc)}
    return {"outcome": "ok", "validate": problems, "make": []}


def argv_case(argv: list[str], cwd: str) -> dict[str, Any]:
    """``tinyrace ARGV`` in ``cwd``: its exit code and what it printed."""
    from tinyrace import cli

    out, err = io.StringIO(), io.StringIO()
    home = os.getcwd()
    os.chdir(cwd)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code if isinstance(exc.code, int) else 2
        finally:
            os.chdir(home)  # the case's folder is removed after the case
    return {
        "outcome": "exit",
        "code": code,
        "stdout": out.getvalue()[-2000:],
        "stderr": err.getvalue()[-2000:],
    }


_ENVS: dict[str, Any] = {}


def options_case(env_name: str, folder: str | None, options: Any) -> dict[str, Any]:
    """reset(options=...) on a cached env, then one step."""
    from tinyrace.env import TinyRaceEnv
    from tinyrace.errors import ConfigError
    from tinyrace.validate import neutral_action

    if env_name not in _ENVS:
        _ENVS[env_name] = TinyRaceEnv(environment=folder) if folder else TinyRaceEnv()
    env = _ENVS[env_name]
    try:
        env.reset(seed=0, options=options)
        env.step(neutral_action(env.action_space))
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    return {"outcome": "ok"}


def _finite_inside(space: Any, observation: Any) -> str | None:
    """Why an observation is not finite or not inside its space (None when it is)."""
    import numpy as np

    arrays = observation.values() if isinstance(observation, dict) else [observation]
    for array in arrays:
        floats = isinstance(array, np.ndarray) and array.dtype.kind == "f"
        if floats and not np.isfinite(array).all():
            return "an observation is not finite"
    if not space.contains(observation):
        return "an observation is outside the observation space"
    return None


def metric_case(folder: str, steps: int = 2) -> dict[str, Any]:
    """Build the env of a track folder, reset it and step it: a ConfigError or a working env
    whose observations are finite and inside the observation space."""
    from tinyrace.env import TinyRaceEnv
    from tinyrace.errors import ConfigError

    try:
        env = TinyRaceEnv(environment=folder)
        try:
            env.action_space.seed(0)
            observation, _ = env.reset(seed=0)
            wrong = _finite_inside(env.observation_space, observation)
            for _ in range(steps):
                if wrong is not None:
                    break
                observation, *_ = env.step(env.action_space.sample())
                wrong = _finite_inside(env.observation_space, observation)
        finally:
            env.close()
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok", "make": []}


def vector_case(args: dict[str, Any]) -> dict[str, Any]:
    """``gym.make_vec`` (the batched vector env) with the given arguments, reset and stepped."""
    import gymnasium as gym

    from tinyrace.errors import ConfigError

    try:
        envs = gym.make_vec("tinyrace/TinyRace-v0", vectorization_mode="vector_entry_point", **args)
        try:
            envs.action_space.seed(0)
            observation, _ = envs.reset(seed=0)
            observation, *_ = envs.step(envs.action_space.sample())
            wrong = _finite_inside(envs.observation_space, observation)
        finally:
            envs.close()
    except ConfigError as exc:
        return {"outcome": "config_error", "make": _problems(exc)}
    if wrong is not None:
        return {"outcome": "bad_observation", "error": wrong}
    return {"outcome": "ok", "make": []}


def probe_case(action: str) -> dict[str, Any]:
    """Misbehaviour on purpose, to show the campaign sees it: too much memory, a hang (blocked:
    the wall-time alarm; a busy loop: the CPU-time one), a death."""
    import time

    if action == "allocate":
        block = bytearray(resource.getrlimit(resource.RLIMIT_AS)[0])
        return {"outcome": "ok", "size": len(block)}
    if action == "sleep":
        time.sleep(3600)
    if action == "spin":
        while True:
            pass
    if action == "die":
        os._exit(3)
    return {"outcome": "ok"}


CASES = {
    "config": config_case,
    "argv": argv_case,
    "options": options_case,
    "probe": probe_case,
    "metric": metric_case,
    "vector": vector_case,
}


def _round4() -> dict[str, Any]:
    """The fourth campaign's kinds (tests/hostile_race_cases.py)."""
    import hostile_race_cases

    return hostile_race_cases.CASES


def _run(case: dict[str, Any], seconds: int) -> dict[str, Any]:
    signal.setitimer(signal.ITIMER_PROF, seconds)
    signal.alarm(seconds * WALL_FACTOR)
    try:
        kind = case["kind"]
        run = CASES[kind] if kind in CASES else _round4()[kind]
        return run(**case["args"])
    except CaseTimeout:
        return {"outcome": "timeout"}
    except MemoryError:
        return {"outcome": "memory"}
    except BaseException:  # anything else is a crash the campaign reports
        return {"outcome": "crash", "error": traceback.format_exc()[-3000:]}
    finally:
        signal.alarm(0)
        signal.setitimer(signal.ITIMER_PROF, 0)


def _read(stream: BinaryIO) -> Any:
    head = stream.read(4)
    if len(head) < 4:
        return None
    (size,) = struct.unpack(">I", head)
    return pickle.loads(stream.read(size))


def _write(stream: BinaryIO, value: Any) -> None:
    data = pickle.dumps(value)
    stream.write(struct.pack(">I", len(data)) + data)
    stream.flush()


def main() -> None:
    memory, seconds = int(sys.argv[1]), int(sys.argv[2])
    answers = os.fdopen(os.dup(1), "wb")
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # C libraries printing to fd 1 cannot break the protocol
    import gymnasium  # noqa: F401 (imports before the limit: only cases are measured)
    import hostile_race_cases  # noqa: F401

    import tinyrace
    import tinyrace.race.opponents  # noqa: F401
    from tinyrace import cli, validate  # noqa: F401

    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    signal.signal(signal.SIGALRM, _alarm)
    signal.signal(signal.SIGPROF, _alarm)
    _write(answers, {"ready": True})
    while (case := _read(sys.stdin.buffer)) is not None:
        _write(answers, _run(case, seconds))


if __name__ == "__main__":
    main()
