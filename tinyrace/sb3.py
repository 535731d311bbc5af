"""Stable-Baselines3's VecEnv over tinyrace's vector env (``BatchVectorEnv``).

SB3's own ``SubprocVecEnv`` runs one env per process and pays a pipe round trip per env
and step; ``BatchVecEnv`` steps several envs per worker through shared memory
(``tinyrace.vector``) and speaks SB3's VecEnv API: same-step autoreset (a finished
env's last observation in ``infos[i]["terminal_observation"]``, the observation
returned its reset one), ``infos[i]["TimeLimit.truncated"]``, float32 rewards, one
info dict per env, ``seed``/``set_options`` applied at the next reset. SB3's wrappers
(``VecFrameStack``, ``VecNormalize``, ``VecMonitor``) go on top. Stable-Baselines3 is an
extra: importing this module imports it.

Example:
    >>> from tinyrace.sb3 import make_vec_env
    >>> from stable_baselines3.common.vec_env import VecFrameStack, VecMonitor
    >>> envs = VecFrameStack(VecMonitor(make_vec_env("tinyrace/CarRacing-v0", 4, workers=2)), 4)
    >>> envs.reset().shape
    (4, 96, 96, 12)
    >>> envs.close()
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from tinyrace.errors import shown
from tinyrace.flat_observations import flat_observation, flat_space, nested_entries
from tinyrace.vector import BatchVectorEnv, make_batch
from tinyrace.vector.arguments import env_indices
from tinyrace.vector.failures import check_autoreset
from tinyrace.vector.make import layout

# the vector env's own arguments: never an env's keyword arguments
OWN_ARGUMENTS = frozenset(inspect.signature(make_batch).parameters) - {"kwargs"}


class BatchVecEnv(VecEnv):  # type: ignore[misc, unused-ignore]  # Any where SB3 is absent
    """An SB3 ``VecEnv`` that steps a ``BatchVectorEnv`` (which it owns and closes)."""

    def __init__(self, venv: BatchVectorEnv):
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)

    # -- stepping ---------------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        """Reset every env with the seeds and options set since the last reset."""
        seeds, options = list(self._seeds), self._options
        if all(o == options[0] for o in options):
            observations, infos = self.venv.reset(seed=seeds, options=options[0] or None)
            self.reset_infos = split_infos(infos, self.num_envs)
        else:  # envs with different options: each group reset on its own
            for chosen in _groups(options):
                mask = np.zeros(self.num_envs, dtype=np.bool_)
                mask[chosen] = True
                group = {**options[chosen[0]], "reset_mask": mask}
                observations, infos = self.venv.reset(seed=seeds, options=group)
                split = split_infos(infos, self.num_envs)
                for index in chosen:
                    self.reset_infos[index] = split[index]
        self._reset_seeds()
        self._reset_options()
        return observations  # type: ignore[no-any-return, unused-ignore]  # the batch

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(actions)

    def step_wait(self) -> VecEnvStepReturn:
        observations, rewards, terminated, truncated, merged = self.venv.step_wait()
        dones = terminated | truncated
        infos = split_infos(merged, self.num_envs)
        for index, info in enumerate(infos):
            info["TimeLimit.truncated"] = bool(truncated[index] and not terminated[index])
        if dones.any():  # the vector env resets them at the next step; SB3 wants it now
            done = np.flatnonzero(dones).tolist()
            for index in done:
                infos[index]["terminal_observation"] = _row(observations, index)
            observations, reset_infos = self.venv.reset(options={"reset_mask": dones})
            after = split_infos(reset_infos, self.num_envs)
            for index in done:
                self.reset_infos[index] = after[index]
        return observations, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    # -- the envs' attributes and methods ---------------------------------------------------
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self.venv.set_attr_at(list(self._get_indices(indices)), attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        chosen = list(self._get_indices(indices))
        results = self.venv.call_at(chosen, method_name, *method_args, **method_kwargs)
        by_index = dict(zip(sorted(set(chosen)), results, strict=True))
        return [by_index[i] for i in chosen]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        wrapped = self.venv.wrapped_by(wrapper_class)
        return [wrapped[i] for i in self._get_indices(indices)]

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds ``seed``, ``seed + 1``, ... for the next reset (None: drawn at random)."""
        if seed is not None:
            _check_seed(seed)
            seed = int(seed)
        return super().seed(seed)  # type: ignore[no-any-return, unused-ignore]

    def set_options(self, options: list[dict[str, Any]] | dict[str, Any] | None = None) -> None:
        """Options for the next reset: one dict for every env, or a list of one per env."""
        listed = [options] if options is None or isinstance(options, dict) else options
        allowed = f"expected None, a dict or a list of {self.num_envs} dicts (one per env)"
        if isinstance(listed, str | bytes) or not isinstance(listed, Sequence):
            raise ValueError(f"options: got {shown(options)}; {allowed}")
        if not isinstance(options, dict | None) and len(listed) != self.num_envs:
            raise ValueError(f"options: got {len(listed)} dicts; {allowed}")
        for option in listed:
            if not isinstance(option, dict | None):
                raise ValueError(f"options: got {shown(option)} among them; {allowed}")
            if option and "reset_mask" in option:
                raise ValueError(
                    "options: 'reset_mask' is not an option here: SB3's reset() resets every "
                    "env (a finished env resets on its own, in step_wait)"
                )
        super().set_options(options)

    def _get_indices(self, indices: VecEnvIndices) -> list[int]:
        """``indices`` (None: every env; an int; or several) as a list of env indices, a
        negative one counted from the end, as SB3's own VecEnvs take them."""
        if indices is None:
            return list(range(self.num_envs))
        return env_indices(indices, self.num_envs, negative=True)

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())


def make_vec_env(
    env_id: str | Callable[..., gym.Env],
    n_envs: int = 1,
    seed: int | None = None,
    workers: int | None = None,
    env_kwargs: dict[str, Any] | None = None,
    parent_steps: bool | None = None,
    *,
    start_index: int = 0,
    wrapper_class: Callable[..., gym.Env] | None = None,
    wrapper_kwargs: dict[str, Any] | None = None,
    **batch_kwargs: Any,
) -> BatchVecEnv:
    """SB3's ``make_vec_env`` for the fast path: ``n_envs`` envs of ``env_id`` (an id for
    ``gym.make`` or a function that makes the env) in ``workers`` processes (by default a
    slice of them per core, this process stepping one: ``tinyrace.vector.make.layout``;
    0: all in this process), seeded ``seed``, ``seed + 1``, ... at the first reset, each
    wrapped in ``wrapper_class(env, **wrapper_kwargs)`` when given (as SB3 does; such an env
    steps on its own, off the batched physics). ``start_index`` is taken as SB3 takes it,
    where it numbers the Monitor files and not the envs' seeds. The other keywords
    are ``make_batch``'s (``context="spawn"``, ``cores``) or, with an id, the env's. Wrap the
    result in ``VecMonitor`` for SB3's episode statistics: SB3's per-env ``Monitor``
    (``monitor_dir``) and its own VecEnv classes (``vec_env_cls``) are not made here."""
    _check_make_args(env_id, seed, env_kwargs)
    _check_sb3_args(start_index, wrapper_class, wrapper_kwargs, batch_kwargs)
    workers, parent_steps = layout(n_envs, workers, parent_steps)
    batch_kwargs["parent_steps"] = parent_steps
    if isinstance(env_id, str) and wrapper_class is None:
        venv = make_batch(env_id, n_envs, workers, **batch_kwargs, **(env_kwargs or {}))
    else:
        own = {k: v for k, v in batch_kwargs.items() if k in OWN_ARGUMENTS}
        check_autoreset(own.pop("autoreset_mode", "NextStep"))  # make_batch's, not the env's
        extra = {k: v for k, v in batch_kwargs.items() if k not in own}
        if extra and not isinstance(env_id, str):
            raise ValueError(
                f"{sorted(extra)[0]!r}: not an argument of make_vec_env; with a function as "
                "env_id, the env's own arguments go in env_kwargs"
            )
        kwargs = {**extra, **(env_kwargs or {})}
        maker = functools.partial(_made, env_id, kwargs, wrapper_class, wrapper_kwargs or {})
        venv = BatchVectorEnv([maker] * n_envs, workers=workers, **own)
    vec = BatchVecEnv(venv)
    if seed is not None:
        vec.seed(seed)
    return vec


# SB3's make_vec_env arguments not taken here, and what to do instead
_NOT_HERE = {
    "monitor_dir": "wrap the result in VecMonitor(venv, filename=...) for a monitor file "
    "(a Monitor per env would take the envs off the batched physics)",
    "monitor_kwargs": "wrap the result in VecMonitor(venv, ...) with those arguments",
    "vec_env_cls": "this VecEnv is tinyrace's own (BatchVecEnv); for SB3's DummyVecEnv or "
    "SubprocVecEnv use stable_baselines3.common.env_util.make_vec_env with the id "
    "'tinyrace:tinyrace/CarRacing-v0'",
    "vec_env_kwargs": "the worker processes' start method is context='spawn' (or "
    "'forkserver', 'fork'); the other options are make_batch's (docs/vector.md)",
}


def _check_sb3_args(
    start_index: object, wrapper_class: object, wrapper_kwargs: object, others: Mapping[str, Any]
) -> None:
    """SB3's own arguments: those taken here checked, those not taken named, before any env
    or worker is made (else they would reach the env's constructor as its arguments)."""
    for name in others:
        if name in _NOT_HERE:
            raise ValueError(f"{name}: not taken by tinyrace.sb3.make_vec_env: {_NOT_HERE[name]}")
    if isinstance(start_index, bool) or not isinstance(start_index, int | np.integer):
        raise ValueError(f"start_index: got {shown(start_index)}; expected a whole number >= 0")
    if start_index < 0:
        raise ValueError(f"start_index: got {start_index}; expected a whole number >= 0")
    if wrapper_class is not None and not callable(wrapper_class):
        raise ValueError(
            f"wrapper_class: got {shown(wrapper_class)}; expected a wrapper class or a function "
            "that takes the env (and wrapper_kwargs) and returns the wrapped env"
        )
    if wrapper_kwargs is not None and not isinstance(wrapper_kwargs, Mapping):
        raise ValueError(
            f"wrapper_kwargs: got {shown(wrapper_kwargs)}; expected a dict of the wrapper's "
            "keyword arguments"
        )


def _made(
    env_id: str | Callable[..., gym.Env],
    kwargs: dict[str, Any],
    wrapper_class: Callable[..., gym.Env] | None,
    wrapper_kwargs: dict[str, Any],
) -> gym.Env:
    """One env, wrapped as asked (module level: a worker process unpickles it by reference,
    importing tinyrace, which registers the ids)."""
    env = gym.make(env_id, **kwargs) if isinstance(env_id, str) else env_id(**kwargs)
    return env if wrapper_class is None else wrapper_class(env, **wrapper_kwargs)


def _check_seed(seed: object) -> None:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed: got {shown(seed)}; expected None or a whole number >= 0")


def _check_make_args(env_id: object, seed: object, env_kwargs: object) -> None:
    """make_vec_env's own arguments, checked before any env or worker is made."""
    if not isinstance(env_id, str) and not callable(env_id):
        raise ValueError(
            f"env_id: got {shown(env_id)}; expected an env id for gym.make "
            '(e.g. "tinyrace/CarRacing-v0") or a function that makes the env'
        )
    if seed is not None:
        _check_seed(seed)
    if env_kwargs is None:
        return
    if not isinstance(env_kwargs, Mapping):
        raise ValueError(
            f"env_kwargs: got {shown(env_kwargs)}; expected a dict of the env's keyword arguments"
        )
    own = sorted(set(env_kwargs) & OWN_ARGUMENTS) if isinstance(env_id, str) else []
    if own:
        name = {"id": "env_id", "num_envs": "n_envs"}.get(own[0], own[0])  # as named here
        raise ValueError(
            f"env_kwargs: {own[0]!r} is an argument of make_vec_env itself, not of the env: "
            f"pass it as make_vec_env(..., {name}=...)"
        )


def split_infos(merged: dict[str, Any], num_envs: int) -> list[dict[str, Any]]:
    """A vector env's merged infos (arrays and ``_key`` masks) as one dict per env."""
    infos: list[dict[str, Any]] = [{} for _ in range(num_envs)]
    for key, values in merged.items():
        mask = merged.get(f"_{key}")
        if mask is None:
            continue  # a mask itself (or a key without one)
        if isinstance(values, dict):
            nested = split_infos(values, num_envs)
            for index in np.flatnonzero(mask):
                infos[index][key] = nested[index]
            continue
        items = values if values.dtype == object else values.tolist()  # Python scalars
        for index in np.flatnonzero(mask):
            infos[index][key] = items[index]
    return infos


def _row(observations: Any, index: int) -> Any:
    if isinstance(observations, dict):
        return {key: value[index].copy() for key, value in observations.items()}
    return observations[index].copy()


def _groups(options: Sequence[dict[str, Any]]) -> list[list[int]]:
    """Env indices grouped by equal options."""
    groups: list[tuple[dict[str, Any], list[int]]] = []
    for index, option in enumerate(options):
        for known, members in groups:
            if known == option:
                members.append(index)
                break
        else:
            groups.append((option, [index]))
    return [members for _, members in groups]


class ModelDriver:
    """A saved Stable-Baselines3 model (``tinyrace train``'s or a script's) as a driver, so
    that ``tinyrace run`` writes its episodes, videos and report::

        driver: tinyrace.sb3:ModelDriver
        driver_args: {model: ppo_f1tenth_lidar.zip}   # algorithm: PPO; deterministic: true

    It gives the model the observation as training did: a dict's entries that are not arrays
    flattened (as ``tinyrace train`` does), and each array stacked along its last axis as
    deep as the model's is over the env's, the newest last and zeros before the first step,
    as SB3's ``VecFrameStack`` stacks (``tinyrace train`` stacks pictures four deep). A
    model trained under ``VecNormalize`` saw normalised observations, whose statistics are
    saved apart from it: this driver does not apply them."""

    def __init__(self, model: str, algorithm: str = "PPO", deterministic: bool = True):
        import stable_baselines3

        from tinyrace.drivers import DriverArgumentError

        found: Any = (
            getattr(stable_baselines3, algorithm, None) if isinstance(algorithm, str) else None
        )
        if not isinstance(found, type):
            names = "A2C, DDPG, DQN, PPO, SAC, TD3"
            raise DriverArgumentError(
                "algorithm", algorithm, f"expected a Stable-Baselines3 algorithm: {names}"
            )
        if not isinstance(model, str) or not Path(model).is_file():
            raise DriverArgumentError(
                "model", model, "expected the path of a saved model (.zip), from the folder run in"
            )
        if not isinstance(deterministic, bool):
            raise DriverArgumentError("deterministic", deterministic, "expected true or false")
        self.model: Any = cast(Any, found).load(model, device="cpu")
        self.deterministic = deterministic
        self._nested: dict[str, gym.Space[Any]] = {}
        self._stacks: dict[str | None, np.ndarray] = {}  # as the env gives them, stacked
        self._transposed: set[str | None] = set()  # pictures the model takes channels-first

    def reset(self, env: gym.Env) -> None:
        """Fit the stacks to ``env``'s observations; a model trained on other observations
        is a DriverError naming both."""
        from tinyrace.drivers import DriverError

        space = env.observation_space
        trained = self.model.observation_space
        self._nested = {}
        given: dict[str | None, gym.Space[Any]]
        wanted: dict[str | None, gym.Space[Any]]
        if isinstance(space, gym.spaces.Dict):  # flattened as tinyrace train flattens it
            self._nested = nested_entries(space)
            given = {key: sub for key, sub in flat_space(space).spaces.items()}
            wanted = {}
            for name, entry in (
                trained.spaces.items() if isinstance(trained, gym.spaces.Dict) else ()
            ):
                wanted[name] = entry
        else:
            given, wanted = {None: space}, {None: trained}
        self._stacks, self._transposed = {}, set()
        for key, sub in given.items():
            want = wanted.get(key)
            stacked = _stacked_shape(
                tuple(sub.shape or ()), tuple(getattr(want, "shape", ()) or ())
            )
            if want is None or stacked is None or set(wanted) != set(given):
                raise DriverError(
                    f"the model was trained on observations {_shapes(trained)}; this env gives "
                    f"{_shapes(space)} (its frames stacked along the last axis at most)"
                )
            shape, transposed = stacked
            if transposed:  # SB3 gave a CNN channels-first pictures (VecTransposeImage)
                self._transposed.add(key)
            self._stacks[key] = np.zeros(shape, dtype=want.dtype)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        if None in self._stacks:
            stacked: Any = self._push(None, observation)
        else:
            flat = flat_observation(self._nested, observation)
            stacked = {key: self._push(key, value) for key, value in flat.items()}
        action, _ = self.model.predict(stacked, deterministic=self.deterministic)
        return action

    def _push(self, key: str | None, value: Any) -> np.ndarray:
        stack = self._stacks[key]
        width = np.shape(value)[-1]
        stack[..., :-width] = stack[..., width:].copy()
        stack[..., -width:] = value
        return np.array(stack.transpose(2, 0, 1) if key in self._transposed else stack)


def _stacked_shape(
    given: tuple[int, ...], wanted: tuple[int, ...]
) -> tuple[tuple[int, ...], bool] | None:
    """The shape of ``given`` stacked to the model's ``wanted`` along its last axis, and
    whether the model takes it channels-first (an (H, W, C) picture as (C, H, W)); None when
    no stack of ``given`` is ``wanted``."""
    if not given or given[-1] <= 0:
        return None
    if len(given) == len(wanted) and given[:-1] == wanted[:-1] and wanted[-1] % given[-1] == 0:
        return wanted, False
    if len(given) == len(wanted) == 3 and wanted[1:] == given[:2] and wanted[0] % given[2] == 0:
        return (*given[:2], wanted[0]), True
    return None


def _shapes(space: gym.Space[Any]) -> str:
    if isinstance(space, gym.spaces.Dict):
        inner = ", ".join(f"{k}: {tuple(s.shape or ())}" for k, s in space.spaces.items())
        return f"{{{inner}}}"
    return str(tuple(space.shape or ()))
