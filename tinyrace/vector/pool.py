"""EnvPool-style asynchronous stepping of a BatchVectorEnv: the first envs ready come back.

``AsyncBatch(vector, batch_size)`` steps a ``BatchVectorEnv``'s workers independently:
``send(actions, env_ids)`` starts the envs ``env_ids`` (whole workers' slices) and
``recv()`` returns as soon as workers holding at least ``batch_size`` envs have answered,
with their env ids in ``infos["env_id"]``. A learner then never waits for the slowest
worker. Each env's own trajectory is what ``SyncVectorEnv`` gives it for the same actions
(next-step autoreset); actions are cast to the action space's dtype.

Example:
    >>> import numpy as np
    >>> from tinyrace.vector import make_batch
    >>> from tinyrace.vector.pool import AsyncBatch
    >>> pool = AsyncBatch(make_batch("tinyrace/CarRacing-v0", 4, workers=2), batch_size=2)
    >>> observations, infos = pool.reset(seed=0)
    >>> pool.send(np.zeros((4, 3), np.float32), np.arange(4))
    >>> observations, rewards, terminated, truncated, infos = pool.recv()
    >>> len(infos["env_id"])
    2
    >>> pool.close()
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from tinyrace.errors import shown
from tinyrace.vector.env import BatchVectorEnv
from tinyrace.vector.failures import check_count
from tinyrace.vector.link import LIVENESS, PARENT_SPIN
from tinyrace.vector.worker import yield_core


class AsyncBatch:
    """Send and receive steps of a BatchVectorEnv's workers one by one (it owns the env)."""

    def __init__(self, vector: BatchVectorEnv, batch_size: int | None = None) -> None:
        if vector._local is not None or vector._views.actions is None:
            raise ValueError(
                "AsyncBatch needs a BatchVectorEnv with worker processes (workers >= 1) "
                "and an array action space"
            )
        if vector._workers.parent is not None:
            raise ValueError(
                "AsyncBatch steps each worker on its own: a BatchVectorEnv made with "
                "parent_steps=True has a slice that only a whole step moves"
            )
        sizes = [s.stop - s.start for s in vector._slices]
        batch_size = vector.num_envs if batch_size is None else batch_size
        check_count(
            "batch_size", batch_size, max(sizes), vector.num_envs, "(one worker's envs to all)"
        )
        self.vector, self.batch_size = vector, batch_size
        self.owner = np.repeat(np.arange(len(sizes)), sizes)  # env id -> worker number
        self.in_flight: list[int] = []  # worker numbers, in the order they were sent

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """``BatchVectorEnv.reset`` (no steps may be in flight)."""
        self._idle("reset")
        return self.vector.reset(**kwargs)

    def send(self, actions: Any, env_ids: Any) -> None:
        """Start stepping the envs ``env_ids`` (every env of each worker they touch, none
        in flight) with ``actions`` (one row per id, in the same order)."""
        vector = self.vector
        vector._check_open()
        ids = self._ids(env_ids)
        workers = sorted(set(self.owner[ids].tolist()))
        for number in workers:
            envs = vector._slices[number]
            if number in self.in_flight or sorted(ids[self.owner[ids] == number]) != list(
                range(envs.start, envs.stop)
            ):
                raise ValueError(
                    f"env_ids must hold every env of worker {number} (envs {envs.start} to "
                    f"{envs.stop - 1}) once, and that worker must not be stepping"
                )
        target = vector._views.actions
        assert target is not None
        expected = (len(ids), *target.shape[1:])
        try:
            rows = np.asarray(actions, dtype=target.dtype)
        except (TypeError, ValueError):  # ragged, or not numbers
            rows = None
        if rows is None or rows.shape != expected:
            got = shown(actions) if rows is None else f"shape {rows.shape}"
            raise ValueError(
                f"actions: expected shape {expected} (a row of {vector.single_action_space} "
                f"per env id), got {got}"
            )
        target[ids] = rows
        if not self.in_flight:  # a buffer no array handed out by reset() refers to
            vector._handout.write(full=False)
        vector._workers.step(workers)
        self.in_flight.extend(workers)

    def recv(self) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The results of the first workers done, at least ``batch_size`` envs (fewer if
        fewer are in flight); ``infos["env_id"]`` says which envs, in the order returned."""
        self.vector._check_open()
        if not self.in_flight:
            raise RuntimeError("recv() with nothing sent: call send() first")
        ready = self._wait()
        vector = self.vector
        ids = np.concatenate(
            [np.arange(vector._slices[n].start, vector._slices[n].stop) for n in ready]
        )
        try:
            infos = vector._answers.collect(vector._views.status, vector._workers.answers, ready)
        except (EOFError, OSError):
            vector.close()
            raise
        infos["env_id"] = ids
        views = vector._views
        observations = views.observations
        if isinstance(observations, dict):
            picked: Any = {key: value[ids] for key, value in observations.items()}
        elif isinstance(observations, tuple):
            picked = tuple(value[ids] for value in observations)
        else:
            picked = observations[ids]
        return picked, views.rewards[ids], views.terminated[ids], views.truncated[ids], infos

    def _ids(self, env_ids: Any) -> np.ndarray:
        """``env_ids`` as an array of env indices, else a ValueError naming them."""
        allowed = f"expected env ids (whole numbers) from 0 to {self.vector.num_envs - 1}"
        try:
            given = np.asarray(env_ids)
        except ValueError:  # ragged
            given = np.asarray([], dtype=np.float64)
        if given.dtype.kind not in "iu" or given.size == 0:
            raise ValueError(f"env_ids: got {shown(env_ids)}; {allowed}")
        ids = given.astype(np.int64).reshape(-1)
        if ids.min() < 0 or ids.max() >= self.vector.num_envs:
            raise ValueError(f"env_ids: got {shown(env_ids)}; {allowed}")
        return ids

    def _wait(self) -> list[int]:
        """Poll the workers in flight until those done hold ``batch_size`` envs (or all)."""
        vector = self.vector
        ready: list[int] = []
        count = 0
        sizes = {n: vector._slices[n].stop - vector._slices[n].start for n in self.in_flight}
        want = min(self.batch_size, sum(sizes.values()))
        start = last_check = time.perf_counter()
        while count < want:
            for number in list(self.in_flight):
                if vector._workers.semaphores[number][1].acquire(False):
                    self.in_flight.remove(number)
                    ready.append(number)
                    count += sizes[number]
                    if count >= want:
                        break
            if count >= want:
                break
            now = time.perf_counter()
            if now - start < PARENT_SPIN:
                yield_core()
            else:
                time.sleep(0.0001)
            if now - last_check > LIVENESS:
                last_check = now
                vector._workers.check_alive(self.in_flight)
        return ready

    def _idle(self, what: str) -> None:
        if self.in_flight:
            raise RuntimeError(f"{what}() while steps are in flight: recv() them first")

    def close(self) -> None:
        """Close the vector env (steps in flight are abandoned)."""
        self.in_flight = []
        self.vector.close()
