"""Many envs' steps done together: the cars' tyre forces as one numpy computation.

``BatchStepper`` steps the envs of a slice whose car model offers its tyre forces as one
computation (``CarModel.batch``, a ``tinyrace.cars.base.TyreBatch``: CarRacing's dynamic
car does). It takes each env's step apart (``TinyRaceEnv.step`` is ``control``, the
episode's step, ``conclude``) and does the car parts for all envs at once:

1. the actions are checked in one go and handed to every car (``TyreBatch.control``);
2. every car's tyre forces, spin and steering in one computation, the new velocities set
   on the bodies, skid marks drawn;
3. stage by stage over the envs: every episode's step with those forces
   (``TinyRaceEnv.advance``: the world steps its pymunk space, the rules find the facts,
   the episode judges its cars), then every observation, and every ``report`` (info).
   Each stage runs the same code env after env, which keeps it hot in the caches.
   ``gym.make``'s ``TimeLimit`` truncates at its limit (read from its public ``spec``)
   counted by the env's own step counter, which counts what the wrapper counts: the
   steps since the reset.

Results are the envs' own ``step`` results, bit for bit. Only envs made by ``gym.make``
(wrappers ``TimeLimit``, ``OrderEnforcing``, ``PassiveEnvChecker``, or none) around a
``TinyRaceEnv`` whose car model has a batch qualify (``BatchStepper.fits``); the first
step goes through the wrappers, so that the env checker makes its one-time checks.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.error import InvalidAction, ResetNeeded
from gymnasium.wrappers import OrderEnforcing, PassiveEnvChecker, TimeLimit

from tinyrace.actions import DISCRETE_CONTROLS, ActionSpec
from tinyrace.cars.base import TyreBatch
from tinyrace.env import TinyRaceEnv

KNOWN_WRAPPERS = (TimeLimit, OrderEnforcing, PassiveEnvChecker)  # gym.make's own
BATCHED_ACTIONS = ("pedals", "discrete")  # actions read as (steer, gas, brake)
# cars from which the tyre forces are one numpy computation. Measured (callgrind, random
# actions): the numpy step costs about 900k instructions + 63k per car (mostly the Python
# per car around it: body reads, velocities, wheel copies, skid marks), the scalar model
# 112k per car; they break even at about 19 cars. With numba (``physics_kernel``) both
# paths run the compiled kernel and cost the same: at 8 envs 762k (the batch kernel,
# numpy_from=1) vs 755k (each car's, numpy_from=20) instructions per env-step
NUMPY_FROM = 20
Step = tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]
Write = Callable[[int, Any], None]  # (env index in the slice, observation)


class BatchStepper:
    """The envs of one slice, stepped together (see the module's docstring)."""

    def __init__(self, envs: Sequence[gym.Env[Any, Any]], numpy_from: int = NUMPY_FROM) -> None:
        self.envs = list(envs)
        self.vectorized = len(self.envs) >= numpy_from  # else each car's own tyre model
        self.cores = [_core(env) for env in self.envs]
        self.limits = [_step_limit(env) for env in self.envs]  # [steps] TimeLimit's, or None
        self.checkers = [_wrapper(env, PassiveEnvChecker) for env in self.envs]
        self.physics = _batch(self.cores[0], len(self.envs))
        self.dt = np.array([core.dt for core in self.cores])  # [s] per env
        actions = self.cores[0].action_spec
        self.actions: ActionSpec = actions
        self._stale = np.ones(len(self.envs), dtype=np.bool_)  # rows to load from their cars
        self._discrete = np.array(DISCRETE_CONTROLS)
        self._every = list(range(len(self.envs)))  # the rows of a step without autoresets
        self._checked = not any(self.checkers)  # every env checker has made its first step
        self.draws_into = all(core.draws_into for core in self.cores)

    @staticmethod
    def fits(envs: Sequence[gym.Env[Any, Any]]) -> bool:
        """Whether every env is a ``TinyRaceEnv`` whose one car model offers a batch, made
        by ``gym.make`` (or bare; a ``TimeLimit`` with its limit in its spec), all with the
        same car model and action space."""
        cores = []
        for env in envs:
            layer: Any = env
            while isinstance(layer, gym.Wrapper):
                if type(layer) not in KNOWN_WRAPPERS:
                    return False
                if type(layer) is TimeLimit and _limit_of(layer) is None:
                    return False
                layer = layer.env
            if not isinstance(layer, TinyRaceEnv) or layer.action_spec.kind not in BATCHED_ACTIONS:
                return False
            if len(layer.course.racers) != 1 or layer.course.car_model.batch is None:
                return False
            cores.append(layer)
        return all(
            (core.action_spec, core.course.car_model)
            == (cores[0].action_spec, cores[0].course.car_model)
            for core in cores
        )

    def invalidate(self) -> None:
        """The cars may have changed outside this stepper (a reset, a call): reload them."""
        self._stale[:] = True

    def step(
        self, actions: Any, autoreset: np.ndarray, write: Write, out: np.ndarray | None = None
    ) -> list[Step | None]:
        """Step the envs not in ``autoreset`` with ``actions``; each one's step results
        (``None`` for the others, which the caller resets). Observations go to ``write``,
        or are drawn straight into their rows of ``out`` (the slice's observations) when
        every env's sensor can (``TinyRaceEnv.draws_into``)."""
        if not self._checked:
            if any(c is not None and not c.checked_step for c in self.checkers):
                return self._step_one_by_one(actions, autoreset, write)
            self._checked = True
        if autoreset.any():
            rows = np.flatnonzero(~autoreset).tolist()
            self._stale |= autoreset  # those rows are reset, not stepped
        else:
            rows = self._every
        cores = self.cores
        for row in rows:
            if cores[row].episode is None:
                raise ResetNeeded("Cannot call env.step() before calling env.reset()")
        if not rows:
            return [None] * len(self.envs)
        if self.vectorized:
            self._forces_together(rows, *self._controls(actions, rows))
        else:
            self._forces_one_by_one(rows, self._control_rows(actions, rows))
        return self._finish(rows, write, out if self.draws_into else None)

    def _forces_together(
        self, rows: list[int], steer: np.ndarray, gas: np.ndarray, brake: np.ndarray
    ) -> None:
        """Every car's controls and tyre forces as one numpy computation (DynamicBatch)."""
        self._load(rows)
        physics, cores = self.physics, self.cores
        physics.control(steer, gas, brake)
        on_road = np.ones((len(self.envs), 4), dtype=np.bool_)
        for row in rows:
            on_road[row] = cores[row].world.wheel_grip()
        physics.apply_forces(self.dt, rows, on_road)
        physics.store(rows)
        physics.track_skids(rows, on_road)

    def _forces_one_by_one(self, rows: list[int], controls: list[Sequence[float]]) -> None:
        """Each car's own ``control`` and ``apply_forces`` (fewer cars than numpy pays for);
        ``controls[i]`` is row ``rows[i]``'s (steer, gas, brake)."""
        cores = self.cores
        for row, (steer, gas, brake) in zip(rows, controls, strict=True):
            core = cores[row]
            world = core.world
            world.control((steer, gas, brake))
            world.apply_forces(core.dt)

    def _finish(self, rows: list[int], write: Write, out: np.ndarray | None) -> list[Step | None]:
        """The rest of the step, stage by stage over the envs of ``rows``: every world and
        its rules, then every env's rewards, then every observation (drawn into its row of
        ``out`` when given), then the results (measured: a stage's code and data stay hot;
        8 envs took 104-106 µs per env-step this way against 122-125 env by env). An
        exception while judging an env (a user's reward shaping) is raised once every other
        env has been judged: those envs stay consistent, the failing one has moved without
        its rewards, as stepping env by env left it."""
        cores, physics = self.cores, self.physics
        judged, error = [], None
        for row in rows:
            core = cores[row]
            try:
                judged.append(core.advance()[0])
            except Exception as exc:
                error = error or exc
            if self.vectorized and core.world.contacts[0].crashed:  # the car stopped its wheels
                physics.stop(row)  # so do the arrays
        if error is not None:
            raise error
        snapshots = [cores[row].snapshot() for row in rows]
        if out is None:
            observations = [cores[row].observe(s) for row, s in zip(rows, snapshots, strict=True)]
        else:  # each into its row: no frame of its own, nothing to write
            observations = [
                cores[row].observe(s, out[row]) for row, s in zip(rows, snapshots, strict=True)
            ]
        results: list[Step | None] = [None] * len(self.envs)
        for row, car, snapshot, observation in zip(
            rows, judged, snapshots, observations, strict=True
        ):
            core = cores[row]
            observation, reward, terminated, truncated, info = core.report(
                car, snapshot, observation
            )
            limit = self.limits[row]
            if limit is not None and core.steps >= limit:  # what TimeLimit.step would say
                truncated = True
            if out is None:
                write(row, observation)
            results[row] = observation, reward, terminated, truncated, info
        return results

    def _load(self, rows: list[int]) -> None:
        """Stepped rows whose car may have changed, loaded from it (the others stay stale)."""
        stale = self._stale
        if not stale.any():
            return
        for row in rows:
            if not stale[row]:
                continue
            core = self.cores[row]
            if core.episode is not None:
                self.physics.load(row, core.world.cars[0])
            stale[row] = False

    def _controls(self, actions: Any, rows: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(steer, gas, brake) per env as float64 columns; checked as ``ActionSpec.read``
        checks, for the envs in ``rows`` (an invalid one raises before anything changes)."""
        spec = self.actions
        n = len(self.envs)
        array = isinstance(actions, np.ndarray)
        if spec.kind == "discrete":
            whole = array and actions.dtype.kind in "iu" and actions.shape == (n,)
            picked = actions if not whole or len(rows) == n else actions[rows]
            if whole and picked.min() >= 0 and picked.max() < len(self._discrete):
                controls = self._discrete[np.clip(actions, 0, len(self._discrete) - 1)]
                return controls[:, 0], controls[:, 1], controls[:, 2]
            return self._read_each(actions, rows)
        if array and actions.dtype == np.float32 and actions.shape == (n, *spec._shape):
            assert isinstance(spec.space, gym.spaces.Box)
            picked = actions if len(rows) == n else actions[rows]
            if (picked >= spec.space.low).all() and (picked <= spec.space.high).all():
                controls = actions.astype(np.float64)
                return controls[:, 0], controls[:, 1], controls[:, 2]
        return self._read_each(actions, rows)

    def _control_rows(self, actions: Any, rows: list[int]) -> list[Sequence[float]]:
        """(steer, gas, brake) of each env in ``rows``, as Python floats, checked as
        ``ActionSpec.read`` checks them (an invalid one raises before anything changes)."""
        spec = self.actions
        if spec.kind == "discrete" or not isinstance(actions, np.ndarray):
            return [self._read(actions[row]) for row in rows]
        if actions.dtype != np.float32 or actions.shape != (len(self.envs), *spec._shape):
            return [self._read(actions[row]) for row in rows]
        values = actions.tolist()  # float32 rows as Python floats: read() gives the same
        bounds = spec._bounds
        controls: list[Sequence[float]] = []
        for row in rows:
            action = values[row]
            for value, (low, high) in zip(action, bounds, strict=True):
                if not low <= value <= high:  # NaN too: read() says what is wrong
                    return [self._read(actions[row]) for row in rows]
            controls.append(action)
        return controls

    def _read(self, action: Any) -> tuple[float, ...]:
        """One action read by ``ActionSpec.read`` (which raises ``InvalidAction``)."""
        values = self.actions.read(action)
        if len(values) != 3:
            raise InvalidAction(f"action {action!r} is not [steer, gas, brake]")
        return values

    def _read_each(
        self, actions: Any, rows: list[int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each action read by ``ActionSpec.read`` (which raises ``InvalidAction``)."""
        controls = np.zeros((len(self.envs), 3))
        for row in rows:
            values = self.actions.read(actions[row])
            if len(values) != 3:
                raise InvalidAction(f"action {actions[row]!r} is not [steer, gas, brake]")
            controls[row] = values
        return controls[:, 0], controls[:, 1], controls[:, 2]

    def _step_one_by_one(
        self, actions: Any, autoreset: np.ndarray, write: Write
    ) -> list[Step | None]:
        """Each env's own ``step`` through its wrappers (the env checker's first step)."""
        results: list[Step | None] = [None] * len(self.envs)
        for row, env in enumerate(self.envs):
            if not autoreset[row]:
                results[row] = step = env.step(actions[row])
                write(row, step[0])
        self.invalidate()
        return results


def _core(env: gym.Env[Any, Any]) -> TinyRaceEnv:
    layer: Any = env
    while isinstance(layer, gym.Wrapper):
        layer = layer.env
    assert isinstance(layer, TinyRaceEnv)
    return layer


def _batch(core: TinyRaceEnv, size: int) -> TyreBatch:
    """The tyre batch of ``size`` cars of ``core``'s car model (``fits`` checked it has one)."""
    make = core.course.car_model.batch
    assert make is not None
    return make(size)


def _limit_of(wrapper: TimeLimit[Any, Any]) -> int | None:
    """A ``TimeLimit``'s limit [steps], read from its public ``spec`` (None: no spec)."""
    spec = wrapper.spec
    return None if spec is None else spec.max_episode_steps


def _step_limit(env: gym.Env[Any, Any]) -> int | None:
    """The limit of the ``TimeLimit`` around ``env``'s core [steps], or None."""
    limit = _wrapper(env, TimeLimit)
    return None if limit is None else _limit_of(limit)


def _wrapper(env: gym.Env[Any, Any], kind: type[Any]) -> Any:
    """The first wrapper of type ``kind`` around ``env``'s core, or None."""
    layer: Any = env
    while isinstance(layer, gym.Wrapper):
        if type(layer) is kind:
            return layer
        layer = layer.env
    return None
