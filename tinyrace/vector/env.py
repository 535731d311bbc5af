"""BatchVectorEnv: several envs per worker process, a step through shared memory.

Gymnasium's ``AsyncVectorEnv`` runs one env per process and pays a pipe round trip
and some pickling per env and step, about as long as a tinyrace step itself. Here,
as in EnvPool, each worker steps a contiguous slice of the envs, and a step moves
nothing through a pipe: actions, observations, rewards, terminations, truncations
and the infos' usual values lie in one shared memory block; a semaphore per worker
and direction wakes the other side (the parent's end: ``tinyrace.vector.link``; the
worker's: ``tinyrace.vector.worker``). Infos of a new shape, and exceptions, go over the
worker's pipe.

Results are those of ``gymnasium.vector.SyncVectorEnv(env_fns)``: next-step
autoreset, ``reset(seed=s)`` seeds env ``i`` with ``s + i``, infos merged with the
same ``_key`` masks. ``render()`` returns the envs' frames as a tuple, like
``SyncVectorEnv``. ``step_async(actions)`` and ``step_wait()`` split a step, so that
the caller can work while the workers step. An exception in a worker is raised again
in the parent, with the worker's traceback as a note (PEP 678), once every worker has
answered; the vector env stays usable, with the envs that stepped before the error
stepped (as in SyncVectorEnv, though here that includes every other worker's envs, and
the other envs of the failing one's slice when they are stepped together: ``batched``).
An exception that does not survive pickling arrives as ``RuntimeError("<Type>:
<message>")``. A worker that dies closes the vector env and raises a RuntimeError
naming it, its envs and its exit code. Closing frees the shared memory.

Example:
    >>> from tinyrace.vector import make_batch
    >>> envs = make_batch("tinyrace/CarRacing-v0", num_envs=8, workers=2)
    >>> observations, infos = envs.reset(seed=0)
    >>> observations.shape
    (8, 96, 96, 3)
    >>> envs.close()
"""

from __future__ import annotations

import itertools
import multiprocessing
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.spaces import Box, Discrete, MultiBinary, MultiDiscrete
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from tinyrace.config.bounds import MAX_ENVS, MAX_WORKERS
from tinyrace.vector import arguments, shared
from tinyrace.vector.answers import Answers
from tinyrace.vector.batched import NUMPY_FROM
from tinyrace.vector.envslice import EnvSlice
from tinyrace.vector.failures import (
    MAIN_GUARD_NOTE,
    NUMPY_FROM_NOTE,
    WorkerDied,
    check_context,
    check_cores,
    check_count,
    check_env,
    check_env_fns,
    check_flag,
)
from tinyrace.vector.handout import Handout, buffers_for
from tinyrace.vector.infos import merge_infos
from tinyrace.vector.link import Workers

StepResult = tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]
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
        copy: return observations that no later step changes, as ``SyncVectorEnv``'s
            ``copy`` (arrays over one of a few buffers the envs write in turn, or copies:
            ``tinyrace.vector.handout``); False returns views of the shared memory,
            overwritten by the next step.
        batch_physics: step the dynamic cars of a process's envs together (their tyre
            forces as one numpy computation, ``tinyrace.vector.batched``); False steps
            each env by its own ``step``, as a process with a single env does either way.
            Results are the same.
        numpy_from: with batched physics, the envs per process from which their cars' tyre
            forces are one numpy computation; fewer cars each run their own tyre model
            (numpy's fixed cost per call outweighs it), still stepped together.
        parent_steps: this process steps a slice of the envs too, alongside the
            ``workers`` processes (``workers + 1`` slices), instead of waiting for them: the
            faster choice when there is a core for each worker and one for the parent
            (``tinyrace.vector.inparent``). Results are the same.
        cores: pin worker process ``i`` to core ``cores[i % len(cores)]`` (Linux; cores
            this process may run on), as EnvPool's ``thread_affinity_offset`` pins its
            threads; None leaves the workers to the OS. With a worker per core the
            scheduler never puts two workers on one core while another core waits: with
            2 workers on 2 cores the stand-ins' ceiling rose about 10% (benchmarks/README.md).
            Pin only cores that are this vector env's alone: two runs pinned to the same
            cores share them, however many others idle. Results are the same.
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        workers: int = 2,
        context: str | None = None,
        copy: bool = True,
        batch_physics: bool = True,
        numpy_from: int = NUMPY_FROM,
        parent_steps: bool = False,
        cores: Sequence[int] | None = None,
    ):
        env_fns = check_env_fns(env_fns)
        check_count("num_envs", len(env_fns), 1, MAX_ENVS, "(len(env_fns))")
        check_count("workers", workers, 0, MAX_WORKERS, "(0: in this process)")
        check_context(context)
        for name, flag in (("copy", copy), ("batch_physics", batch_physics)):
            check_flag(name, flag)
        check_flag("parent_steps", parent_steps)
        check_count("numpy_from", numpy_from, 1, MAX_ENVS + 1, NUMPY_FROM_NOTE)
        pinned = check_cores(cores, workers)
        self.env_fns, self.copy = env_fns, copy
        self.num_envs = len(env_fns)
        self.autoreset_mode = AutoresetMode.NEXT_STEP
        self._local: EnvSlice | None = None  # workers=0: the envs, stepped in this process
        self._memory: Any = None
        self._pending = False
        self._pending_local: StepResult | None = None  # workers=0: step_async's results
        self._by_pipe = False  # the pending step's actions went over the pipes
        # The shared memory must exist before the workers start, so the spaces come from
        # an env made here (as AsyncVectorEnv does).
        probe = check_env(env_fns[0](), env_fns[0])
        self.metadata = {**probe.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = probe.render_mode
        self.single_observation_space = probe.observation_space
        self.single_action_space = probe.action_space
        probe.close()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._array_actions = isinstance(self.single_action_space, ARRAY_ACTIONS)
        if not shared.shareable(self.single_observation_space):
            raise TypeError(
                f"BatchVectorEnv shares observations of Box, Discrete, MultiBinary and "
                f"MultiDiscrete spaces (or Dicts and Tuples of them), not "
                f"{self.single_observation_space}: use gymnasium.vector.SyncVectorEnv"
            )
        parent_steps = bool(parent_steps) and workers > 0
        count = min(max(workers, 1) + parent_steps, self.num_envs)  # slices
        if parent_steps and count == 1:  # a single env: the parent steps it, no process
            workers, parent_steps = 0, False
        bounds = np.linspace(0, self.num_envs, count + 1)
        self._slices = [slice(a, b) for a, b in itertools.pairwise(bounds.astype(int))]
        self._workers = Workers(self._slices, self.close, parent_steps)
        spaces = (self.single_observation_space, self.single_action_space, self.num_envs)
        layout = shared.Layout(*spaces, len(self._slices))
        layout = shared.Layout(*spaces, len(self._slices), buffers_for(layout, copy))
        if workers == 0:
            block = bytearray(layout.size)
            self._views = layout.views(block)
            self._handout = Handout(block, layout, self._views)
            self._local = EnvSlice(env_fns, 0, self._views, batch_physics, numpy_from)
            self._check_spaces([self._local.spaces()])
            return
        self._memory = shared.create_block(layout.size)
        self._views = layout.views(self._memory.buf)
        self._handout = Handout(self._memory.buf, layout, self._views)
        try:
            self._workers.start(
                multiprocessing.get_context(context),
                self.env_fns,
                (self._memory.name, layout),
                self._views,
                (batch_physics, numpy_from),
                pinned,
            )
            self._check_spaces(self._workers.receive_all())
        except BaseException as error:  # e.g. an env that cannot be made in a worker
            self.close()
            method = context or multiprocessing.get_start_method()
            if isinstance(error, WorkerDied) and method != "fork":
                note = MAIN_GUARD_NOTE.format(method=method)
                if hasattr(error, "add_note"):  # Python >= 3.11
                    error.add_note(note)
                else:
                    error.args = (f"{error.args[0]}\n{note}",)
            raise
        views = self._views
        self._answers = Answers(views.infos, views.kinds, self._slices, views.uniform)

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
        seed = arguments.seeds(seed, self.num_envs)
        options, mask = arguments.reset_options(options, self.num_envs)
        self._check_idle("reset")
        self._handout.write(full=bool(mask.all()))
        try:
            replies = self._exchange("reset", [(seed[s], options, mask[s]) for s in self._slices])
        except Exception:
            self._restore(None)
            raise
        # None: not in the reset mask
        return self._observations_out(), merge_infos(_flat(replies), self.num_envs)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env; an env whose episode ended at the last step is reset instead."""
        if self._local is not None:  # in this process: no messages, no slicing
            self._check_open()
            batch = self._batch(actions)
            self._handout.write(full=True)
            try:
                return self._results(*self._local.step(batch))
            except Exception:
                self._restore(None)
                raise
        self.step_async(actions)
        return self.step_wait()

    def step_async(self, actions: Any) -> None:
        """Start a step; ``step_wait`` returns its results."""
        self._check_open()
        if self._pending:
            raise gym.error.AlreadyPendingCallError(
                "step_async was called again before step_wait", "step"
            )
        if self._local is not None:
            self._pending_local = self.step(actions)
            self._pending = True
            return
        batch = self._batch(actions)
        self._handout.write(full=True)
        target = self._views.actions
        if target is None or batch.dtype != target.dtype or batch.shape != target.shape:
            # a Dict action space, or actions that casting would change: over the pipes
            self._workers.send("step", [(batch[s],) for s in self._slices])
            self._pending = True
            self._by_pipe = True
            return
        target[:] = batch
        self._workers.step()
        self._pending = True
        self._by_pipe = False

    def step_wait(self) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The results of the step ``step_async`` started."""
        self._check_open()
        if not self._pending:
            raise gym.error.NoAsyncCallError("step_wait was called before step_async", "step")
        self._pending = False
        if self._local is not None:
            results = self._pending_local
            assert results is not None
            self._pending_local = None
            return results
        if self._by_pipe:
            try:
                replies = self._workers.receive_all()
            except Exception:
                self._restore(None)
                raise
            return self._results(*map(_flat, zip(*replies, strict=True)))
        self._workers.wait_all()
        try:
            infos = self._answers.collect(self._views.status, self._workers.answers)
        except (EOFError, OSError):  # a worker died after its "done"
            self.close()
            raise
        except Exception:
            self._restore(self._views.status.tolist())
            raise
        views = self._views
        return (
            self._observations_out(),
            views.rewards.copy(),
            views.terminated.copy(),
            views.truncated.copy(),
            infos,
        )

    def _results(
        self,
        rewards: Sequence[Any],
        terminated: Sequence[Any],
        truncated: Sequence[Any],
        env_infos: Sequence[dict[str, Any]],
    ) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """A step's results from per-env lists (in this process, or by the pipes)."""
        return (
            self._observations_out(),
            np.array(rewards, dtype=np.float64),
            np.array(terminated, dtype=np.bool_),
            np.array(truncated, dtype=np.bool_),
            merge_infos(env_infos, self.num_envs),
        )

    def render(self) -> tuple[Any, ...]:
        """The frames of the envs, as a tuple (``SyncVectorEnv.render``)."""
        return self.call("render")

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every env (or read the attribute); a tuple of results."""
        replies = self._exchange("call", [(name, args, kwargs)] * len(self._slices))
        return tuple(_flat(replies))

    def call_at(
        self, indices: Sequence[int], name: str, *args: Any, **kwargs: Any
    ) -> tuple[Any, ...]:
        """``call`` for the envs in ``indices`` only (in increasing order of index)."""
        only = sorted(set(arguments.env_indices(indices, self.num_envs)))
        replies = self._exchange("call", [(name, args, kwargs, only)] * len(self._slices))
        return tuple(_flat(replies))

    def set_attr_at(self, indices: Sequence[int], name: str, value: Any) -> None:
        """Set attribute ``name`` of the envs in ``indices`` to ``value``."""
        only = sorted(set(arguments.env_indices(indices, self.num_envs)))
        self._exchange(
            "set_attr", [(name, [value] * (s.stop - s.start), only) for s in self._slices]
        )

    def wrapped_by(self, kind: type[Any]) -> tuple[bool, ...]:
        """Whether each env has a wrapper of type ``kind``."""
        return tuple(_flat(self._exchange("wrapped_by", [(kind,)] * len(self._slices))))

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
        self._workers.close()
        self._views = self._answers = self._handout = None  # type: ignore[assignment]
        memory, self._memory = self._memory, None
        shared.free_block(memory)

    def __del__(self) -> None:
        # a constructor that raised before the workers' end existed has nothing to close
        if not getattr(self, "closed", True) and hasattr(self, "_workers"):
            self.close()

    # -- messages ---------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed:
            raise gym.error.ClosedEnvironmentError("BatchVectorEnv was closed")

    def _check_idle(self, command: str) -> None:
        self._check_open()
        if self._pending:
            raise gym.error.AlreadyPendingCallError(
                f"{command} was called while a step was pending: call step_wait first", "step"
            )

    def _exchange(self, command: str, args: list[tuple[Any, ...]]) -> list[Any]:
        """Send each worker its command and arguments; every worker's answer, in order."""
        self._check_idle(command)
        if self._local is not None:  # in this process: the slice's own exceptions
            return [getattr(self._local, command)(*args[0])]
        self._workers.send(command, args)
        return self._workers.receive_all()

    def _batch(self, actions: Any) -> Any:
        """The actions as one batch to slice: an array for array spaces, else a list."""
        return arguments.actions_batch(
            actions, self.action_space, self.single_action_space, self.num_envs, self._array_actions
        )

    def _restore(self, status: list[int] | None) -> None:
        """After a step or reset that raised: the rows of the workers that failed (None:
        every row, when it is not known which) as they were before it."""
        if self.closed:  # a worker died: nothing left to restore
            return
        for number, rows in enumerate(self._slices):
            if status is None or status[number] == shared.FAILED:
                self._handout.restore(rows)

    def _observations_out(self) -> Any:
        """Views of the shared memory (``copy=False``), else arrays no later step changes."""
        if not self.copy:
            return self._views.observations
        return self._handout.hand_out()


def _flat(per_worker: Sequence[list[Any]]) -> list[Any]:
    return list(itertools.chain.from_iterable(per_worker))
