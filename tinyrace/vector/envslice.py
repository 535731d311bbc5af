"""The envs of one slice of a BatchVectorEnv: stepped in this process or in a worker's."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from tinyrace.vector.batched import NUMPY_FROM, BatchStepper
from tinyrace.vector.infos import check_infos
from tinyrace.vector.shared import Views

# envs per slice from which their steps go through ``BatchStepper``'s stages: one env
# alone costs more that way than by its own ``step`` (benchmarks/README.md, issue 37)
BATCH_FROM = 2


class EnvSlice:
    """One worker's envs: envs ``first``, ``first + 1``, ... of the vector env."""

    def __init__(
        self,
        env_fns: list[Callable[[], gym.Env[Any, Any]]],
        first: int,
        views: Views,
        batch_physics: bool = True,
        numpy_from: int = NUMPY_FROM,
    ):
        self.envs = [fn() for fn in env_fns]
        self.first = first
        # dynamic cars: their tyre forces computed together (else each env's own step)
        fits = batch_physics and len(self.envs) >= BATCH_FROM and BatchStepper.fits(self.envs)
        self.batch = BatchStepper(self.envs, numpy_from) if fits else None
        self.views = views
        self.autoreset = [False] * len(self.envs)  # envs whose episode ended at the last step
        # the observation array last written and this slice's rows of it (a slice made per
        # step costs more than kept, on the caches an env step leaves cold: benchmarks/README.md)
        self._target: Any = None
        self._target_rows: np.ndarray | None = None

    def spaces(self) -> list[tuple[gym.Space[Any], gym.Space[Any]]]:
        return [(env.observation_space, env.action_space) for env in self.envs]

    def reset(
        self, seeds: list[int | None], options: dict[str, Any] | None, mask: np.ndarray
    ) -> list[dict[str, Any] | None]:
        infos: list[dict[str, Any] | None] = []
        for j, env in enumerate(self.envs):
            if not mask[j]:
                infos.append(None)
                continue
            try:
                observation, info = env.reset(seed=seeds[j], options=options)
                check_infos([info], self.first + j)  # None here means "not reset"
            except Exception as error:
                _blame(error, self.first + j)
                raise
            self._write(j, observation)
            self.autoreset[j] = False
            infos.append(info)
        self._invalidate()
        return infos

    def step(
        self, actions: Any
    ) -> tuple[list[SupportsFloat], list[bool], list[bool], list[dict[str, Any]]]:
        """Step every env (an env whose episode ended at the last step is reset instead):
        rewards, terminations, truncations and infos, as lists (they pickle faster). An
        info that is no dict raises here, as Gymnasium's merge would."""
        n = len(self.envs)
        if n == 1:  # no batch, no loops: every object touched after the env's step is cold
            return self._step_single(actions)
        results = self._step_each(actions) if self.batch is None else self._step_batch(actions)
        _, terminated, truncated, infos = results
        if terminated.count(False) == n and truncated.count(False) == n:  # the common step
            self.autoreset = [False] * n  # (each equal to False: _flag gives False)
        else:
            self.autoreset = [
                _flag(a) or _flag(b) for a, b in zip(terminated, truncated, strict=True)
            ]
        if list(map(type, infos)).count(dict) != n:
            check_infos(infos, self.first)
        return results

    def _step_single(
        self, actions: Any
    ) -> tuple[list[SupportsFloat], list[bool], list[bool], list[dict[str, Any]]]:
        """``step`` of a slice of one env: ``_step_each``'s results, written alike."""
        observation, reward, terminated, truncated, info = self._step_env(0, actions[0])
        rows = self._rows()
        if rows is not None:
            rows[0] = observation
        else:
            _write_nested(self.views.observations, self.first, observation)
        self.autoreset = [_flag(terminated) or _flag(truncated)]
        if type(info) is not dict:
            check_infos([info], self.first)
        return [reward], [terminated], [truncated], [info]

    def _step_batch(
        self, actions: Any
    ) -> tuple[list[SupportsFloat], list[bool], list[bool], list[dict[str, Any]]]:
        """``step`` through ``BatchStepper``'s stages; the envs to reset after them."""
        assert self.batch is not None
        n = len(self.envs)
        mask = np.array(self.autoreset, dtype=np.bool_)
        results = self.batch.step(actions, mask, self._write, self._rows())
        rewards: list[SupportsFloat] = [0.0] * n
        terminated, truncated = [False] * n, [False] * n
        infos: list[dict[str, Any]] = [{}] * n
        for j, result in enumerate(results):
            if result is None:  # the episode ended at the last step: _step_env resets it
                observation, _, _, _, infos[j] = self._step_env(j, None)
                self._write(j, observation)
                continue
            _, rewards[j], terminated[j], truncated[j], infos[j] = result
        return rewards, terminated, truncated, infos

    def _step_each(
        self, actions: Any
    ) -> tuple[list[SupportsFloat], list[bool], list[bool], list[dict[str, Any]]]:
        """``step`` by each env's own ``step`` (or ``reset``), env after env, the
        observations written once all have stepped, as SyncVectorEnv goes (an env that
        raises leaves every row of the slice as it was)."""
        n, first = len(self.envs), self.first
        rewards: list[SupportsFloat] = [0.0] * n
        terminated, truncated = [False] * n, [False] * n
        infos: list[dict[str, Any]] = [{}] * n
        observations: list[Any] = [None] * n
        for j in range(n):
            observations[j], rewards[j], terminated[j], truncated[j], infos[j] = self._step_env(
                j, actions[j]
            )
        rows = self._rows()  # None: a Dict or Tuple space, written leaf by leaf
        if rows is not None:
            _write_rows(rows, observations)
        else:
            for j, observation in enumerate(observations):
                _write_nested(self.views.observations, first + j, observation)
        return rewards, terminated, truncated, infos

    def _step_env(self, j: int, action: Any) -> tuple[Any, SupportsFloat, Any, Any, Any]:
        """Env ``j``'s step with ``action``; its reset instead if its episode ended at the
        last step (reward 0, not done). An exception gets a note naming the env."""
        env = self.envs[j]
        try:
            if self.autoreset[j]:
                observation, info = env.reset()
                return observation, 0.0, False, False, info
            observation, reward, terminated, truncated, info = env.step(action)
        except Exception as error:
            _blame(error, self.first + j)
            raise
        return observation, reward, terminated, truncated, info

    def call(
        self,
        name: str,
        args: tuple[Any, ...],
        kwargs: dict[str, Any],
        only: Sequence[int] | None = None,
    ) -> list[Any]:
        """Call method ``name`` of each env (or read the attribute); ``only``: those envs
        (vector env indices), the others left alone."""
        results = []
        for j, env in enumerate(self.envs):
            if only is not None and self.first + j not in only:
                continue
            attribute = env.get_wrapper_attr(name)
            results.append(attribute(*args, **kwargs) if callable(attribute) else attribute)
        self._invalidate()
        return results

    def wrapped_by(self, kind: type[Any]) -> list[bool]:
        """Whether each env has a wrapper of type ``kind`` (a subclass counts)."""
        found = []
        for env in self.envs:
            layer: Any = env
            while isinstance(layer, gym.Wrapper) and not isinstance(layer, kind):
                layer = layer.env
            found.append(isinstance(layer, kind))
        return found

    def set_attr(self, name: str, values: Sequence[Any], only: Sequence[int] | None = None) -> None:
        """Set attribute ``name`` of each env to its value; ``only``: those envs (vector
        env indices), the others left alone."""
        for j, (env, value) in enumerate(zip(self.envs, values, strict=True)):
            if only is None or self.first + j in only:
                env.set_wrapper_attr(name, value)
        self._invalidate()

    def _invalidate(self) -> None:
        """The envs may have changed (reset, called, set): the batch reloads its cars."""
        if self.batch is not None:
            self.batch.invalidate()

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def _rows(self) -> np.ndarray | None:
        """This slice's rows of a Box observation's array (None: a Dict or Tuple space)."""
        target = self.views.observations
        if target is self._target:  # the buffer of the last step
            return self._target_rows
        self._target = target
        if not isinstance(target, np.ndarray):
            self._target_rows = None
        else:
            self._target_rows = target[self.first : self.first + len(self.envs)]
        return self._target_rows

    def _write(self, j: int, observation: Any) -> None:
        target = self.views.observations
        if isinstance(target, np.ndarray):
            target[self.first + j] = observation  # a Box: one array
        else:
            _write_nested(target, self.first + j, observation)


def _flag(value: Any) -> bool:
    """``value`` as numpy casts it into SyncVectorEnv's flag arrays (a step may return
    numpy scalars); a ``bool`` as it is, without a numpy call."""
    if type(value) is bool:
        return value
    return bool(np.array(value, dtype=np.bool_))


def _blame(error: Exception, index: int) -> None:
    """Add a note naming the env that raised ``error`` (kept when it is pickled)."""
    if hasattr(error, "add_note"):  # Python >= 3.11
        error.add_note(f"raised by env {index}")


def _write_rows(rows: np.ndarray, observations: list[Any]) -> None:
    """Observation ``j`` into ``rows[j]``: arrays of the rows' dtype and shape as one
    copy (``np.concatenate`` along the first axis, no numpy call per row: 25 of 75 µs
    for 32 CarRacing frames, benchmarks/README.md), anything else row by row, cast and
    broadcast as numpy assigns (a single one too: its row costs less than the checks)."""
    if rows.ndim >= 2 and len(observations) > 1:
        try:
            # each one as long as a row (so no two unequal lengths add up to the rows'), and
            # of their dtype (``casting="no"``); ``tall`` is a view: ``rows`` is contiguous
            if set(map(len, observations)) == {rows.shape[1]}:
                tall = rows.reshape(-1, *rows.shape[2:])
                np.concatenate(observations, out=tall, casting="no")
                return
        except (TypeError, ValueError):  # a scalar, a dtype or shape of its own: one by one
            pass
    for j, observation in enumerate(observations):
        rows[j] = observation


def _write_nested(target: Any, index: int, observation: Any) -> None:
    if isinstance(target, dict):
        for key, view in target.items():
            _write_nested(view, index, observation[key])
    elif isinstance(target, tuple):
        for view, part in zip(target, observation, strict=True):
            _write_nested(view, index, part)
    else:
        target[index] = observation
