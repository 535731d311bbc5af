"""BatchVectorEnv: several envs per worker process, one message per worker per step.

Gymnasium's ``AsyncVectorEnv`` runs one env per process and pays a pipe round trip
and some pickling per env and step, about as long as a tinyrace step itself. Here,
as in EnvPool, each worker steps a contiguous slice of the envs per message: the
parent sends each worker one batch of actions, the workers write observations
straight into shared memory and answer with their rewards, terminations,
truncations and infos.

Results are those of ``gymnasium.vector.SyncVectorEnv(env_fns)``: next-step
autoreset, ``reset(seed=s)`` seeds env ``i`` with ``s + i``, infos merged with the
same ``_key`` masks. ``render()`` returns the envs' frames as a tuple, like
``SyncVectorEnv``. An exception in a worker is raised again in the parent, with
the worker's traceback as a note (PEP 678), once every worker has answered; the
vector env stays usable, with the envs that stepped before the error stepped (as
in SyncVectorEnv, though here that includes every other worker's envs, and the other
envs of the failing one's slice when they are stepped together: ``batched``). An
exception that does not survive pickling arrives as ``RuntimeError("<Type>: <message>")``.
A worker that dies closes the vector env and raises a RuntimeError naming it.

Between commands a worker polls its pipe for ``WORKER_SPIN`` before it sleeps
(yielding its core to any other process meanwhile): a training loop that calls
``step`` again within that time skips the worker's wake-up.

Example:
    >>> from tinyrace.vector import make_batch
    >>> envs = make_batch("tinyrace/CarRacing-v0", num_envs=8, workers=2)
    >>> observations, infos = envs.reset(seed=0)
    >>> observations.shape
    (8, 96, 96, 3)
    >>> envs.close()
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import multiprocessing
import os
import pickle
from collections.abc import Callable, Sequence
from copy import deepcopy
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.spaces import Box, Discrete, MultiBinary, MultiDiscrete
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import (
    CloudpickleWrapper,
    batch_space,
    create_shared_memory,
    iterate,
    read_from_shared_memory,
)

from tinyrace.config.bounds import MAX_ENVS, MAX_WORKERS
from tinyrace.errors import ConfigError, Problem
from tinyrace.vector.batched import NUMPY_FROM
from tinyrace.vector.infos import merge_infos
from tinyrace.vector.worker import CLOSED, _Slice, work

CLOSE_TIMEOUT = 10.0  # [s] a worker gets to finish its command and close its envs
ARRAY_ACTIONS = (Box, Discrete, MultiBinary, MultiDiscrete)  # batched actions are one array


class BatchVectorEnv(VectorEnv):
    """``len(env_fns)`` envs in ``workers`` processes, each stepping a contiguous slice.

    Args:
        env_fns: functions that make the envs; with ``context="spawn"`` they are sent
            with cloudpickle, so the env ids they make must be importable there
            (``"tinyrace:tinyrace/CarRacing-v0"`` or ``make_batch`` do that).
        workers: processes to run the envs in (at most one per env); 0 runs them all
            in this process, with no pipe and no pickling.
        context: ``multiprocessing`` start method; ``None`` for the platform default.
        copy: return a copy of the observations (else views of the shared memory,
            overwritten by the next step), as ``SyncVectorEnv``'s ``copy``.
        batch_physics: step the dynamic cars of a process's envs together (their tyre
            forces as one numpy computation, ``tinyrace.vector.batched``); False steps
            each env by its own ``step``. Results are the same.
        numpy_from: with batched physics, the envs per process from which their cars' tyre
            forces are one numpy computation; fewer cars each run their own tyre model
            (numpy's fixed cost per call outweighs it), still stepped together.
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        workers: int = 2,
        context: str | None = None,
        copy: bool = True,
        batch_physics: bool = True,
        numpy_from: int = NUMPY_FROM,
    ):
        env_fns = list(env_fns)
        _check_count("num_envs", len(env_fns), 1, MAX_ENVS, "(len(env_fns))")
        _check_count("workers", workers, 0, MAX_WORKERS, "(0: in this process)")
        self.env_fns, self.copy = env_fns, copy
        self.num_envs = len(env_fns)
        self.autoreset_mode = AutoresetMode.NEXT_STEP
        self._pipes: list[Connection] = []
        self._processes: list[multiprocessing.process.BaseProcess] = []
        self._local: _Slice | None = None  # workers=0: the envs, stepped in this process
        # The shared memory must exist before the workers start, so the spaces come from
        # an env made here (as AsyncVectorEnv does).
        probe = env_fns[0]()
        self.metadata = {**probe.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = probe.render_mode
        self.single_observation_space = probe.observation_space
        self.single_action_space = probe.action_space
        probe.close()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

        ctx = multiprocessing.get_context(context)
        self._buffer = create_shared_memory(self.single_observation_space, self.num_envs, ctx)  # type: ignore[arg-type]
        self._observations = read_from_shared_memory(
            self.single_observation_space, self._buffer, self.num_envs
        )
        bounds = np.linspace(0, self.num_envs, min(max(workers, 1), self.num_envs) + 1)
        self._slices = [slice(a, b) for a, b in itertools.pairwise(bounds.astype(int))]
        memory = (self._buffer, self.single_observation_space, self.num_envs)
        if workers == 0:
            self._local = _Slice(env_fns, 0, memory, batch_physics, numpy_from)
            self._check_spaces([self._local.spaces()])
            return
        for number, envs in enumerate(self._slices):
            parent, child = ctx.Pipe()
            fns = [CloudpickleWrapper(fn) for fn in env_fns[envs]]
            process = ctx.Process(  # type: ignore[attr-defined]
                target=work,
                args=(child, parent, fns, envs.start, memory, batch_physics, numpy_from),
                name=f"BatchVectorEnv-worker-{number}",
                daemon=True,
            )
            process.start()
            child.close()
            self._pipes.append(parent)
            self._processes.append(process)
        try:
            self._check_spaces(self._receive_all())
        except Exception:  # e.g. an env that cannot be made in a worker
            self.close()
            raise

    def _check_spaces(self, replies: list[list[tuple[gym.Space[Any], gym.Space[Any]]]]) -> None:
        """Every env must have the first env's spaces, as in SyncVectorEnv."""
        expected = (self.single_observation_space, self.single_action_space)
        for index, spaces in enumerate(_flat(replies)):
            if spaces != expected:
                raise RuntimeError(
                    f"env {index} has the spaces {spaces}, env 0 has {expected}: "
                    "a BatchVectorEnv's envs must share their observation and action spaces"
                )

    # -- gymnasium API ----------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every env (or those in ``options["reset_mask"]``), as SyncVectorEnv does."""
        if seed is None:
            seed = [None] * self.num_envs
        elif isinstance(seed, int):
            seed = [seed + i for i in range(self.num_envs)]
        if len(seed) != self.num_envs:
            raise ValueError(
                f"If seeds are passed as a list the length must match num_envs={self.num_envs} "
                f"but got length={len(seed)}."
            )
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options is not None and "reset_mask" in options:
            options = dict(options)  # unlike SyncVectorEnv, leave the caller's dict alone
            mask = _check_reset_mask(options.pop("reset_mask"), self.num_envs)
        replies = self._exchange("reset", [(seed[s], options, mask[s]) for s in self._slices])
        # None: not in the reset mask
        return self._observations_out(), merge_infos(_flat(replies), self.num_envs)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env; an env whose episode ended at the last step is reset instead."""
        if self._local is not None:  # in this process: no messages, no slicing
            rewards, terminated, truncated, env_infos = self._local.step(self._batch(actions))
        else:
            batch = self._batch(actions)
            replies = self._exchange("step", [(batch[s],) for s in self._slices])
            # the workers' slices are contiguous and in order: flattened, item i is env i's
            rewards, terminated, truncated, env_infos = map(_flat, zip(*replies, strict=True))
        infos = merge_infos(env_infos, self.num_envs)
        return (
            self._observations_out(),
            np.array(rewards, dtype=np.float64),
            np.array(terminated, dtype=np.bool_),
            np.array(truncated, dtype=np.bool_),
            infos,
        )

    def render(self) -> tuple[Any, ...]:
        """The frames of the envs, as a tuple (``SyncVectorEnv.render``)."""
        return self.call("render")

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every env (or read the attribute); a tuple of results."""
        replies = self._exchange("call", [(name, args, kwargs)] * len(self._slices))
        return tuple(_flat(replies))

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every env."""
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set attribute ``name`` of every env: one value for all or a list of one per env."""
        if not isinstance(values, list | tuple):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                "Values must be a list or tuple with length equal to the number of environments. "
                f"Got `{len(values)}` values for {self.num_envs} environments."
            )
        self._exchange("set_attr", [(name, values[s]) for s in self._slices])

    @property
    def np_random_seed(self) -> tuple[int, ...]:  # type: ignore[override]
        """The seeds of the envs' random generators."""
        return self.get_attr("np_random_seed")

    @property  # type: ignore[misc]  # read-only here: the envs own their generators
    def np_random(self) -> tuple[np.random.Generator, ...]:  # type: ignore[override]
        """Copies of the envs' random generators."""
        return self.get_attr("np_random")

    def close_extras(self, **kwargs: Any) -> None:
        """Close the envs, stop the workers (terminating any that hang), free the memory."""
        if self._local is not None:
            self._local.close()
            self._local = None
        for pipe in self._pipes:
            with contextlib.suppress(OSError):  # a worker that is gone already
                pipe.send(("close", ()))
        for pipe, process in zip(self._pipes, self._processes, strict=True):
            _await_close(pipe)
            pipe.close()
            process.join(CLOSE_TIMEOUT)
            if process.is_alive():
                process.terminate()
                process.join()
        self._pipes, self._processes = [], []
        self._observations = self._buffer = None  # type: ignore[assignment]  # memory freed

    def __del__(self) -> None:
        if not self.closed and hasattr(self, "_local"):
            self.close()

    # -- messages ---------------------------------------------------------------------------
    def _exchange(self, command: str, args: list[tuple[Any, ...]]) -> list[Any]:
        """Send each worker its command and arguments; every worker's answer, in order."""
        if self.closed:
            raise gym.error.ClosedEnvironmentError("BatchVectorEnv was closed")
        if self._local is not None:  # in this process: the slice's own exceptions
            return [getattr(self._local, command)(*args[0])]
        # all pickled first: an argument that cannot be pickled leaves the pipes in step
        messages = [ForkingPickler.dumps((command, worker_args)) for worker_args in args]
        for pipe, message in zip(self._pipes, messages, strict=True):
            with contextlib.suppress(OSError):  # a dead worker: reported by _receive_all
                pipe.send_bytes(message)
        return self._receive_all()

    def _receive_all(self) -> list[Any]:
        """Every worker's answer, in order; the first worker's exception is raised here."""
        replies = []
        for number, pipe in enumerate(self._pipes):
            try:
                replies.append(pipe.recv())
            except (EOFError, OSError):  # no answer will ever come
                process = self._processes[number]
                self.close()
                raise RuntimeError(
                    f"BatchVectorEnv worker {number} (envs {_show(self._slices[number])}) "
                    f"died without an answer (exit code {process.exitcode})"
                ) from None
            except BaseException:  # e.g. Ctrl-C: the pipes would be out of step
                self.close()
                raise
        for number, (ok, result) in enumerate(replies):
            if not ok:
                raise _rebuild_error(result, number, self._slices[number])
        return [result for _, result in replies]

    def _batch(self, actions: Any) -> Any:
        """The actions as one batch to slice: an array for array spaces, else a list."""
        if isinstance(self.single_action_space, ARRAY_ACTIONS):
            batch: Any = np.asarray(actions)
        else:
            batch = list(iterate(self.action_space, actions))
        if len(batch) != self.num_envs:
            raise ValueError(f"expected actions for {self.num_envs} envs, got {len(batch)}")
        return batch

    def _observations_out(self) -> Any:
        if not self.copy:
            return self._observations
        if isinstance(self._observations, np.ndarray):
            return self._observations.copy()  # as deepcopy, without its memo
        return deepcopy(self._observations)


def make_batch(
    id: str,
    num_envs: int,
    workers: int = 2,
    *,
    context: str | None = None,
    batch_physics: bool = True,
    numpy_from: int = NUMPY_FROM,
    **kwargs: Any,
) -> BatchVectorEnv:
    """A BatchVectorEnv of ``num_envs`` copies of ``gym.make(id, **kwargs)``; ``workers=0``
    steps them all in this process."""
    _check_count("num_envs", num_envs, 1, MAX_ENVS)
    maker = functools.partial(_make, id, kwargs)
    return BatchVectorEnv(
        [maker] * num_envs,
        workers=workers,
        context=context,
        batch_physics=batch_physics,
        numpy_from=numpy_from,
    )


def make_carracing_vec(
    num_envs: int = 1, workers: int | None = None, **kwargs: Any
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/CarRacing-v0", vectorization_mode="vector_entry_point")``."""
    return make_batch("tinyrace/CarRacing-v0", num_envs, _workers(num_envs, workers), **kwargs)


def make_tinyrace_vec(
    num_envs: int = 1, workers: int | None = None, **kwargs: Any
) -> BatchVectorEnv:
    """``gym.make_vec("tinyrace/TinyRace-v0", vectorization_mode="vector_entry_point")``."""
    return make_batch("tinyrace/TinyRace-v0", num_envs, _workers(num_envs, workers), **kwargs)


def _workers(num_envs: int, workers: int | None) -> int:
    """One worker process per core by default, never more than envs."""
    _check_count("num_envs", num_envs, 1, MAX_ENVS)
    return workers if workers is not None else max(1, min(num_envs, os.cpu_count() or 1))


def _check_count(name: str, value: object, low: int, high: int, note: str = "") -> None:
    """A whole number from ``low`` to ``high``, else a ConfigError naming the argument."""
    whole = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if whole and low <= int(value) <= high:  # type: ignore[call-overload]
        return
    allowed = f"expected a whole number from {low} to {high} {note}".rstrip()
    raise ConfigError(Problem("<make_vec arguments>", name, value, allowed))


def _make(id: str, kwargs: dict[str, Any]) -> gym.Env:
    # pickled by reference to this module: a spawned worker imports tinyrace, registering its ids
    return gym.make(id, **kwargs)


def _check_reset_mask(mask: Any, num_envs: int) -> np.ndarray:
    """``options["reset_mask"]``, checked as SyncVectorEnv does."""
    if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
        raise TypeError(f"`options['reset_mask']` must be a numpy array of bools, got {mask!r}")
    if mask.shape != (num_envs,) or not mask.any():
        raise ValueError(
            f"`options['reset_mask']` must have shape `({num_envs},)` and a True value, got {mask}"
        )
    return mask


def _flat(per_worker: Sequence[list[Any]]) -> list[Any]:
    return list(itertools.chain.from_iterable(per_worker))


def _show(envs: slice) -> str:
    return f"{envs.start}-{envs.stop - 1}" if envs.stop - envs.start > 1 else str(envs.start)


def _rebuild_error(
    error: tuple[str, str, str, bytes | None], number: int, envs: slice
) -> Exception:
    """The worker's exception (or a RuntimeError naming it), its traceback as a note."""
    name, message, trace, pickled = error
    rebuilt: Exception | None = None
    with contextlib.suppress(Exception):
        rebuilt = pickle.loads(pickled) if pickled is not None else None
    if rebuilt is None or str(rebuilt) != message:  # exceptions whose args are not the message
        rebuilt = RuntimeError(f"{name}: {message}")
    note = f"raised in BatchVectorEnv worker {number} (envs {_show(envs)}):\n{trace}"
    if hasattr(rebuilt, "add_note"):  # Python >= 3.11
        rebuilt.add_note(note)
    return rebuilt


# -- the worker process -------------------------------------------------------------------------
def _await_close(pipe: Connection) -> None:
    """Read answers until the worker confirms "close" (answers to an interrupted command
    may come first), it exits, or CLOSE_TIMEOUT passes."""
    try:
        while pipe.poll(CLOSE_TIMEOUT):
            _, result = pipe.recv()
            if isinstance(result, str) and result == CLOSED:
                return
    except (EOFError, OSError):
        return
