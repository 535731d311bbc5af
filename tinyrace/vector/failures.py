"""What a BatchVectorEnv says when its arguments or its workers fail."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import signal
from collections.abc import Callable, Iterable, Sequence
from multiprocessing.connection import Connection
from typing import Any

import gymnasium as gym
import numpy as np

from tinyrace.errors import ConfigError, Problem, shown
from tinyrace.vector.worker import CLOSED


def check_count(name: str, value: object, low: int, high: int, note: str = "") -> None:
    """A whole number from ``low`` to ``high``, else a ConfigError naming the argument."""
    whole = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if whole and low <= int(value) <= high:  # type: ignore[call-overload]
        return
    allowed = f"expected a whole number from {low} to {high} {note}".rstrip()
    raise ConfigError(Problem("<make_vec arguments>", name, value, allowed))


def check_flag(name: str, value: object) -> None:
    """True or False (numpy's bools too), else a ConfigError naming the argument."""
    if not isinstance(value, (bool, np.bool_)):
        raise ConfigError(Problem("<make_vec arguments>", name, value, "expected true or false"))


def check_autoreset(mode: object) -> None:
    """Gymnasium's ``autoreset_mode`` argument: a BatchVectorEnv resets an env at the step
    after its episode ended (NEXT_STEP), the only mode it has."""
    from gymnasium.vector import AutoresetMode

    if mode in (AutoresetMode.NEXT_STEP, AutoresetMode.NEXT_STEP.value):
        return
    allowed = (
        "expected AutoresetMode.NEXT_STEP ('NextStep'): a BatchVectorEnv resets an env at the "
        "step after its episode ends; for SAME_STEP or DISABLED use gym.make_vec's sync or "
        "async vectorization_mode"
    )
    raise ConfigError(Problem("<make_vec arguments>", "autoreset_mode", mode, allowed))


NUMPY_FROM_NOTE = "(envs per process from which their tyre forces are one computation; more: never)"


def check_context(context: object) -> None:
    """None or a start method of ``multiprocessing`` on this platform."""
    methods = multiprocessing.get_all_start_methods()
    if context is not None and context not in methods:
        allowed = f"expected None (the platform's default) or one of {methods}"
        raise ConfigError(Problem("<make_vec arguments>", "context", context, allowed))


def check_env_fns(env_fns: object) -> list[Callable[[], Any]]:
    """``env_fns`` as a list of functions, else a ConfigError naming the first that is not."""
    allowed = "expected a list of functions that make an env (e.g. [lambda: gym.make(id)] * n)"
    if isinstance(env_fns, str | bytes) or not isinstance(env_fns, Iterable):
        raise ConfigError(Problem("<make_vec arguments>", "env_fns", env_fns, allowed))
    fns = list(env_fns)
    for index, fn in enumerate(fns):
        if not callable(fn):
            raise ConfigError(Problem("<make_vec arguments>", f"env_fns[{index}]", fn, allowed))
    return fns


def check_env(env: object, fn: object) -> gym.Env[Any, Any]:
    """What ``fn`` made, if it is a Gymnasium env, else a TypeError naming both."""
    if not isinstance(env, gym.Env):
        raise TypeError(f"env_fns[0] ({fn!r}) returned {shown(env)}, not a gymnasium.Env")
    return env


def check_cores(cores: object, workers: int) -> list[int] | None:
    """``cores`` as a list of cores this process may run on (None stays None), else a
    ConfigError naming the argument and what is allowed."""
    if cores is None:
        return None
    if not hasattr(os, "sched_setaffinity"):
        allowed = "pinning workers to cores needs os.sched_setaffinity (Linux); pass None"
        raise ConfigError(Problem("<make_vec arguments>", "cores", cores, allowed))
    usable = sorted(os.sched_getaffinity(0))
    allowed = f"expected a list of cores from the ones this process may run on: {usable}"
    whole = (int, np.integer)
    if (
        isinstance(cores, str | bytes)
        or not isinstance(cores, Sequence | np.ndarray)
        or len(cores) == 0
        or any(isinstance(c, bool | np.bool_) or not isinstance(c, whole) for c in cores)
    ):
        raise ConfigError(Problem("<make_vec arguments>", "cores", cores, allowed))
    chosen = [int(c) for c in cores]
    outside = [c for c in chosen if c not in usable]
    if outside:
        raise ConfigError(Problem("<make_vec arguments>", "cores", outside, allowed))
    if len(set(chosen)) < len(chosen):
        allowed = "expected each core once (fewer cores than workers share them out in turn)"
        raise ConfigError(Problem("<make_vec arguments>", "cores", cores, allowed))
    if workers == 0:
        allowed = "cores pins worker processes: with workers=0 there are none; pass None"
        raise ConfigError(Problem("<make_vec arguments>", "cores", cores, allowed))
    return chosen


def show(envs: slice) -> str:
    """A slice of envs as "3" or "3-5"."""
    return f"{envs.start}-{envs.stop - 1}" if envs.stop - envs.start > 1 else str(envs.start)


class WorkerDied(RuntimeError):
    """A worker process ended without answering (a RuntimeError, as it always was)."""


# noted when a worker started by spawn or forkserver dies before its first answer
MAIN_GUARD_NOTE = (
    "A worker started by {method!r} imports the main script again before it makes its envs: "
    'a script that makes the vector env outside `if __name__ == "__main__":` starts it there '
    "too, which ends the worker (its error is printed above)."
)


def died(number: int, envs: slice, exitcode: int | None) -> WorkerDied:
    """The error for worker ``number`` (stepping ``envs``) that ended without an answer."""
    how = f"exit code {exitcode}"
    if exitcode is not None and exitcode < 0:
        names = {s.value: s.name for s in signal.Signals}
        how = f"killed by {names.get(-exitcode, f'signal {-exitcode}')}"
    return WorkerDied(
        f"BatchVectorEnv worker {number} (envs {show(envs)}) died without an answer ({how}); "
        "the vector env is closed"
    )


def rebuild_error(
    error: tuple[str, str, str, bytes | None] | Exception, number: int, envs: slice
) -> Exception:
    """The worker's exception (or a RuntimeError naming it), its traceback as a note; an
    exception raised by the parent's own slice (``tinyrace.vector.inparent``) as it is."""
    if isinstance(error, Exception):
        if hasattr(error, "add_note"):  # Python >= 3.11
            error.add_note(f"raised in the BatchVectorEnv's parent process (envs {show(envs)})")
        return error
    name, message, trace, pickled = error
    rebuilt: Exception | None = None
    with contextlib.suppress(Exception):
        rebuilt = pickle.loads(pickled) if pickled is not None else None
    if rebuilt is None or str(rebuilt) != message:  # exceptions whose args are not the message
        rebuilt = RuntimeError(f"{name}: {message}")
    note = f"raised in BatchVectorEnv worker {number} (envs {show(envs)}):\n{trace}"
    if hasattr(rebuilt, "add_note"):  # Python >= 3.11
        rebuilt.add_note(note)
    return rebuilt


def await_close(pipe: Connection, timeout: float) -> None:
    """Read answers until the worker confirms "close" (answers to an interrupted command
    may come first), it exits, or ``timeout`` passes."""
    try:
        while pipe.poll(timeout):
            message = pipe.recv()
            closed = isinstance(message, tuple) and len(message) == 2
            if closed and isinstance(message[1], str) and message[1] == CLOSED:
                return
    except (EOFError, OSError):
        return
