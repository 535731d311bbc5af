"""Infos as records in shared memory: each env's record with its own signature, merged as
``VectorEnv._add_info`` merges the infos themselves (``merge_infos``), bit for bit.

A property test writes random lists of infos (keys of several types, keys missing in some
envs, nested dicts, tuples, numpy numbers) into records and compares the merge with
``merge_infos``; a vector env whose envs disagree on most steps (``Tiles``) matches
SyncVectorEnv's results and sends no info over a pipe.
"""

from __future__ import annotations

import copy
import itertools
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples
from vector_doubles import Flags, Huge, NoInfo, NumpyBool, Quiet, Tiles

from tests.test_batch_vector import assert_same, run
from tinyrace.vector import BatchVectorEnv
from tinyrace.vector.answers import Answers
from tinyrace.vector.infos import merge_infos
from tinyrace.vector.records import (
    INFO_BYTES,
    Plan,
    _leaves,
    flatten,
    record_dtype,
    record_struct,
    records,
)

FLOATS = st.floats(allow_nan=False, width=64)
SCALARS = {
    "speed": FLOATS,
    "n": st.integers(-(2**63), 2**63 - 1),
    "on": st.booleans(),
    "small": st.floats(allow_nan=False, width=32).map(np.float32),
    "lap": st.integers(-(2**31), 2**31 - 1).map(np.int32),
    "pose": st.lists(FLOATS, min_size=1, max_size=4).map(tuple),  # lengths may differ
}
ANY = st.one_of(*SCALARS.values())


def infos(depth: int = 2) -> st.SearchStrategy[dict[str, Any]]:
    """Infos whose keys mostly keep one type (as an env's do), with a key ``wild`` of any
    type and nested dicts under ``terms``."""
    entries = [st.tuples(st.just(key), value) for key, value in SCALARS.items()]
    entries.append(st.tuples(st.just("wild"), ANY))
    if depth:
        entries.append(st.tuples(st.just("terms"), infos(depth - 1)))
    return st.lists(st.one_of(*entries), max_size=6).map(dict)


def merged_by_records(batch: list[dict[str, Any]]) -> dict[str, Any]:
    """Write ``batch`` into records, one signature number per distinct signature, and merge
    them as the parent does."""
    rows = np.zeros((len(batch), INFO_BYTES), np.uint8)
    numbers: dict[Any, int] = {}
    kinds = np.zeros(len(batch), np.int64)
    for index, info in enumerate(batch):
        signature, flat = flatten(info)
        kinds[index] = numbers.setdefault(signature, len(numbers))
        record_struct(signature).pack_into(rows[index], 0, *flat)  # as a worker packs
    answers = Answers(rows, kinds, [slice(0, len(batch))])
    answers._announce(0, list(numbers))
    return answers._merge(kinds, rows, cache=True)


@pytest.mark.filterwarnings("ignore:overflow encountered in cast:RuntimeWarning")  # a wild key
@settings(max_examples=examples(400), deadline=None)
@given(st.lists(infos(), min_size=1, max_size=6))
def test_records_merge_as_merge_infos(batch):
    try:
        expected = merge_infos(batch, len(batch))
    except (ValueError, TypeError, OverflowError, AttributeError) as error:
        with pytest.raises(type(error)):  # as SyncVectorEnv's step would raise
            merged_by_records(batch)
        return
    assert_same(expected, merged_by_records(batch))


@settings(max_examples=examples(200), deadline=None)
@given(infos(), st.integers(1, 6), st.integers(1, 3))
def test_one_signature_in_every_env_merges_as_merge_infos(info, num_envs, workers):
    """The common case: every worker says its envs' infos share one signature (``uniform``)
    and the parent merges them without looking at each env's number."""
    batch = [copy.deepcopy(info) for _ in range(num_envs)]
    signature, flat = flatten(info)
    rows = np.zeros((num_envs, INFO_BYTES), np.uint8)
    for row in rows:
        record_struct(signature).pack_into(row, 0, *flat)
    bounds = np.linspace(0, num_envs, min(workers, num_envs) + 1).astype(int)
    slices = [slice(a, b) for a, b in itertools.pairwise(bounds)]
    uniform = np.zeros(len(slices), np.int64)
    answers = Answers(rows, np.zeros(num_envs, np.int64), slices, uniform)
    for number in range(len(slices)):
        answers._announce(number, [signature])
    status = np.zeros(len(slices), np.int64)
    merged = answers.collect(status, [None] * len(slices))
    assert answers._common() == 0
    assert_same(merge_infos(batch, num_envs), merged)
    uniform[-1] = -1  # one worker's envs disagree: each env's number is read
    assert answers._common() is None
    assert_same(merge_infos(batch, num_envs), answers.collect(status, [None] * len(slices)))


@pytest.mark.parametrize(
    "batch",
    [
        [{"a": 1.0}, {"a": 2}],  # one key, two types: the infos one by one
        [{"d": {"x": 1.0}}, {"d": 2.0}],  # a dict and a value under one key
        [{}, {"t": (1.0, 2.0)}, {"t": (3.0,)}],  # tuples of two lengths; an empty info
        [{"a": {"b": {"c": True}}}, {"a": {}}, {"a": {"b": {}}}],
    ],
)
def test_records_merge_disagreeing_infos_as_merge_infos(batch):
    assert_same(merge_infos(batch, len(batch)), merged_by_records(batch))


def test_a_plan_keeps_keys_in_order_of_first_appearance():
    rows = np.zeros((2, INFO_BYTES), np.uint8)
    plan = Plan.of([(0, flatten({"x": 1.0})[0]), (1, flatten({"y": 1, "x": 2.0})[0])], rows)
    assert plan is not None
    assert list(plan.merge(np.array([0, 1]))) == ["x", "_x", "y", "_y"]
    assert list(plan.merge(np.array([1, 0]))) == ["x", "_x", "y", "_y"]  # the plan's order


def test_numpy_bools_go_by_pipe_as_sync_vector_env_merges_them():
    """_add_info keeps np.bool_ values as objects (it is no np.number)."""
    assert flatten({"b": np.bool_(True)}) is None
    got = run(BatchVectorEnv([NumpyBool] * 2, workers=1), steps=3)
    expected = run(gym.vector.SyncVectorEnv([NumpyBool] * 2), steps=3)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    assert got[-1][-1]["b"].dtype == object


@pytest.mark.parametrize(("num_envs", "workers"), [(8, 2), (5, 1), (3, 3)])
def test_envs_that_disagree_write_records_not_pipe_messages(num_envs, workers):
    expected = run(gym.vector.SyncVectorEnv([Tiles] * num_envs), steps=60)
    batch = BatchVectorEnv([Tiles] * num_envs, workers=workers)
    by_pipe = []
    one_by_one = batch._answers._one_by_one

    def counted(*args):
        by_pipe.append(args)
        return one_by_one(*args)

    batch._answers._one_by_one = counted
    plans = batch._answers.plans
    got = run(batch, steps=60)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    assert by_pipe == []
    assert any(len(order) > 1 for order in plans)  # steps whose envs disagreed


@pytest.mark.parametrize(("num_envs", "workers"), [(8, 2), (3, 1)])
def test_steps_of_empty_infos_merge_as_sync_vector_env(num_envs, workers):
    """Workers whose envs all give an empty info write no record (``uniform``); steps where
    some env gives one merge as SyncVectorEnv's do."""
    expected = run(gym.vector.SyncVectorEnv([Quiet] * num_envs), steps=60)
    batch = BatchVectorEnv([Quiet] * num_envs, workers=workers)
    answers = batch._answers
    alike, merge_alike = [], answers._merge_alike

    def counted(number):
        alike.append(answers.signatures[number])
        return merge_alike(number)

    answers._merge_alike = counted
    got = run(batch, steps=60)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    empty = sum(not info for *_, info in got[1:])
    assert empty >= 5 and alike.count(()) == empty  # steps with no info in any env
    assert any(len(order) > 1 for order in answers.plans)  # and steps with some


@pytest.mark.parametrize("workers", [0, 1])
def test_an_int_no_record_holds_raises_as_in_sync_vector_env(workers):
    """A 70-bit int fits no record (struct refuses it): the infos go by pipe and the merge
    raises SyncVectorEnv's OverflowError; the steps before are SyncVectorEnv's, and the
    vector env steps on afterwards."""
    outcomes = []
    zeros = np.zeros((2, 1), np.float32)
    for vector in (gym.vector.SyncVectorEnv([Huge] * 2), BatchVectorEnv([Huge] * 2, workers)):
        vector.reset(seed=0)
        outcomes.append([vector.step(zeros) for _ in range(2)])
        with pytest.raises(OverflowError):
            vector.step(zeros)
        if isinstance(vector, BatchVectorEnv):  # every env stepped: the next infos fit
            assert vector.step(zeros)[-1]["n"].tolist() == [4, 4]
        vector.close()
    for step, (a, b) in enumerate(zip(*outcomes, strict=True)):
        assert_same(a, b, f"step {step}")


@pytest.mark.parametrize(
    "info",
    [
        {"x": -0.0, "n": -(2**63), "on": True, "f": np.float32(-np.inf), "g": np.float64(np.nan)},
        {"i": np.int32(-(2**31)), "j": np.int64(2**63 - 1), "t": (np.inf, -0.0, 5e-324)},
        {"q": np.float32(np.nan), "d": {"e": {"x": 1.5, "b": False}}, "m": 2**63 - 1},
    ],
)
def test_struct_packs_the_bytes_numpy_writes(info):
    """``record_struct`` lays a record out as ``record_dtype`` does: packing the flat values
    gives numpy's bytes for the same info (extremes, signed zeros, quiet NaNs included)."""
    signature, flat = flatten(info)
    packed, written = np.zeros((2, INFO_BYTES), np.uint8)
    record_struct(signature).pack_into(packed, 0, *flat)
    row, values = records(written[None], record_dtype(signature))[0], iter(flat)
    for name, (kind, length) in zip(row.dtype.names, _leaves(signature), strict=True):
        row[name] = [next(values) for _ in range(length)] if kind is tuple else next(values)
    assert packed.tobytes() == written.tobytes()


@pytest.mark.parametrize(("num_envs", "workers"), [(2, 0), (2, 1), (2, 2), (1, 0)])
def test_an_info_of_none_raises_as_in_sync_vector_env(num_envs, workers):
    """None is no empty info (nor a missing one): a step or a reset that gives it raises
    what Gymnasium's merge raises for it, in this process and in a worker (and in a slice
    of one env, stepped on its own)."""
    zeros = np.zeros((num_envs, 1), np.float32)
    sync = gym.vector.SyncVectorEnv([NoInfo] * num_envs)
    for vector in (sync, BatchVectorEnv([NoInfo] * num_envs, workers)):
        vector.reset(seed=0)
        assert vector.step(zeros)[-1] == {}
        with pytest.raises(AttributeError, match="'NoneType' object has no attribute 'items'"):
            vector.step(zeros)
        with pytest.raises(AttributeError, match="'NoneType' object has no attribute 'items'"):
            vector.reset(options={"no_info": True})
        vector.close()


@pytest.mark.parametrize(("num_envs", "workers"), [(6, 0), (6, 2), (3, 1), (2, 2)])
def test_episode_ends_of_any_type_autoreset_as_in_sync_vector_env(num_envs, workers):
    """Terminations and truncations as numpy bools, ints and numpy ints (steps with only
    plain bools take the one-pass path): the same flags and autoresets as SyncVectorEnv."""
    expected = run(gym.vector.SyncVectorEnv([Flags] * num_envs), steps=80)
    got = run(BatchVectorEnv([Flags] * num_envs, workers=workers), steps=80)
    for step, (a, b) in enumerate(zip(expected, got, strict=True)):
        assert_same(a, b, f"step {step}")
    ends = sum(int(np.sum(t | u)) for _, _, t, u, _ in got[1:])
    assert ends >= 10  # autoresets happened, after ends of every kind
