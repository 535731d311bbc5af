"""``merge_infos`` against Gymnasium's own merge (``VectorEnv._add_info``, env by env), bit
for bit: the same keys in the same order, the same dtypes, shapes and bytes, the same
objects, and the same exception where Gymnasium's merge raises.

Batches are drawn two ways: infos that mostly share their keys (the common step, whose
values may still differ in type from env to env) and unrelated infos, with missing infos
(None) and empty ones among them.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pytest
from gymnasium.vector import VectorEnv
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tests.test_batch_physics import assert_same  # bit for bit: bytes, NaNs, signed zeros
from tinyrace.vector.infos import merge_infos

FLOATS = st.floats(width=64)  # NaNs, infinities and signed zeros included
VALUES = {
    "speed": FLOATS,
    "n": st.integers(-(2**63), 2**63 - 1),
    "on": st.booleans(),
    "small": st.floats(allow_nan=False, width=32).map(np.float32),
    "lap": st.integers(-(2**31), 2**31 - 1).map(np.int32),
    "pose": st.lists(FLOATS, min_size=1, max_size=3).map(tuple),
    "flag": st.booleans().map(np.bool_),  # no np.number: Gymnasium keeps it as an object
    "name": st.text(max_size=3),
    "grid": st.integers(0, 3).map(lambda k: np.full((2,), k, np.int16)),
}
# any value at all, under any key: a key whose type changes from env to env
ANY = st.one_of(
    *VALUES.values(),
    st.integers(),  # also past 64 bits
    st.none(),
    st.just(np.float64(-0.0)),
    st.just([1, 2]),
)


def infos(depth: int = 1) -> st.SearchStrategy[dict[str, Any]]:
    """Unrelated infos: a few of the keys above, each mostly of its own type."""
    entries = [st.tuples(st.just(k), st.one_of(v, v, v, ANY)) for k, v in VALUES.items()]
    if depth:
        entries.append(st.tuples(st.just("terms"), infos(depth - 1)))
    return st.lists(st.one_of(*entries), max_size=5).map(dict)


@st.composite
def alike(draw: st.DrawFn, depth: int = 1) -> list[Any]:
    """Infos of one env's shape: the same keys in every env (in the first env's order or
    shuffled), values of each key's type but now and then of another, now and then a
    missing (None) or empty info."""
    keys = draw(st.lists(st.sampled_from([*VALUES, "terms", "final_obs"]), unique=True))
    n = draw(st.integers(1, 6))
    batch: list[Any] = []
    nested = draw(alike(depth - 1)) if depth and "terms" in keys else None
    for index in range(n):
        info: dict[str, Any] = {}
        for key in draw(st.permutations(keys)) if draw(st.booleans()) else keys:
            if key == "terms":
                info[key] = nested[index % len(nested)] if nested is not None else {}
            elif key == "final_obs":
                info[key] = np.full(3, index, np.float32)
            else:
                info[key] = draw(st.one_of(*[VALUES[key]] * 6, ANY))
        batch.append(draw(st.sampled_from([info] * 8 + [None, {}])))
    return batch


def merged_by_gymnasium(batch: list[Any]) -> dict[str, Any]:
    """What SyncVectorEnv makes of the envs' infos: ``_add_info`` env by env."""

    class Merger(VectorEnv):
        num_envs = len(batch)

    merger, merged = Merger(), dict[str, Any]()
    for index, info in enumerate(batch):
        if info is not None:
            merged = merger._add_info(merged, info, index)
    return merged


def check(batch: list[Any]) -> None:
    """``merge_infos`` gives what Gymnasium gives, or raises what it raises."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # casts of out-of-range values warn alike in both
        try:
            expected = merged_by_gymnasium(batch)
        except Exception as error:
            with pytest.raises(type(error)):
                merge_infos(batch, len(batch))
            return
        assert_same(expected, merge_infos(batch, len(batch)))


@settings(max_examples=examples(400), deadline=None)
@given(alike())
@example([{"a": 1.0}, {"a": 2}])  # an int among floats: cast to the first env's float
@example([{"a": 1}, {"a": 2.5}])  # a float among ints: cast to int, as Gymnasium does
@example([{"a": True}, {"a": 2}])  # an int among bools
@example([{"a": 1.0}, {"a": np.float32(0.1)}])
@example([{"a": 1}, {"a": np.uint64(2**64 - 1)}])  # numpy would make both floats
@example([{"a": 1}, {"a": 2**63}])  # an int past int64: OverflowError, as Gymnasium's
@example([{"a": 1.0}, {"a": (1.0, 2.0)}])  # numpy would refuse the list outright
@example([{"a": (1.0,)}, {"a": [1.0]}])  # a list among tuples: kept as the object it is
@example([{"a": -0.0}, {"a": 0.0}])
@example([{"a": 1.0, "b": 2}, {"b": 3, "a": 4.0}])  # the first env's key order
@example([{"a": 1.0, "b": 2}, {"a": 4.0, "c": 3}])  # as many keys, not the same ones
@example([{"a": {"x": 1.0}}, {"a": 2.0}])  # a dict and a value under one key
@example([{"a": 1.0}, None])
@example([{"a": 1.0}, []])  # an info that is no dict: Gymnasium's AttributeError
def test_infos_of_one_shape_merge_as_gymnasium_merges_them(batch):
    check(batch)


@settings(max_examples=examples(300), deadline=None)
@given(st.lists(st.one_of(infos(), st.none()), min_size=1, max_size=6))
def test_unrelated_infos_merge_as_gymnasium_merges_them(batch):
    check(batch)


def test_every_array_and_mask_is_its_own():
    """No two keys share an array: a caller may change one (as Gymnasium's are)."""
    batch = [{"a": 1.0, "b": 2, "c": (1.0,), "d": {"e": True}} for _ in range(4)]
    merged = merge_infos(batch, 4)
    arrays = [merged[k] for k in ("a", "_a", "b", "_b", "c", "_c", "_d")]
    arrays += list(merged["d"].values())
    assert len({id(a) for a in arrays}) == len(arrays)
    assert not any(np.shares_memory(x, y) for i, x in enumerate(arrays) for y in arrays[:i])
    assert all(a.flags.writeable for a in arrays)
