"""The parent's reading of its workers' step answers: infos from the shared records (or
the pipes), exceptions from the pipes."""

from __future__ import annotations

from collections.abc import Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from tinyrace.vector import shared
from tinyrace.vector.failures import rebuild_error
from tinyrace.vector.infos import merge_infos
from tinyrace.vector.inparent import ParentPipe
from tinyrace.vector.records import Plan, Signature, record_dtype, records, unflatten

MAX_PLANS = 256  # merge plans kept (one per order of signatures met); then they start anew


class Answers:
    """The info signatures the workers announced, numbered once for all workers, and the
    merge plans of the records over the whole batch."""

    def __init__(
        self,
        infos: np.ndarray,
        kinds: np.ndarray,
        slices: list[slice],
        uniform: np.ndarray | None = None,
    ) -> None:
        self.infos, self.kinds, self.slices = infos, kinds, slices
        # per worker: its number of the one signature of all its envs' infos, or -1
        self.uniform = uniform
        self.signatures: list[Signature] = []  # by number
        self.dtypes: list[np.dtype] = []  # their records' layouts
        self.numbers: dict[Signature, int] = {}
        # per worker: its numbers of signatures -> the common numbers; as one table
        # (worker, its number) -> common number, and each env's worker
        self.known: list[list[int]] = [[] for _ in slices]
        self.table = np.zeros((len(slices), 0), np.int64)
        self.worker_of = np.repeat(np.arange(len(slices)), [s.stop - s.start for s in slices])
        self.plans: dict[tuple[int, ...], Plan | None] = {}  # by signatures in order

    def collect(
        self,
        status: np.ndarray,
        pipes: Sequence[Connection | ParentPipe],
        numbers: list[int] | None = None,
    ) -> dict[str, Any]:
        """The step's merged infos of the workers ``numbers`` (default: all), their envs in
        that order: from the records when every worker wrote them, else each env's info
        (from its record or the pipe), merged. A worker's exception is raised once every
        worker's answer is read (the pipes stay in step)."""
        codes = status.tolist()  # one call, not a numpy scalar per worker
        whole = numbers is None
        if whole and codes.count(shared.KNOWN) == len(codes):  # the common step
            return self._merge_whole()
        numbers = list(range(len(pipes))) if numbers is None else numbers
        by_pipe: dict[int, list[dict[str, Any]]] = {}
        error: Exception | None = None
        for number in numbers:
            code = codes[number]
            if code == shared.KNOWN:
                continue
            pipe = pipes[number]
            if code == shared.FAILED:
                _, described = pipe.recv()
                error = error or rebuild_error(described, number, self.slices[number])
            elif code == shared.INFOS_BY_PIPE:
                by_pipe[number] = pipe.recv()
            else:
                self._announce(number, pipe.recv())
        if error is not None:
            raise error
        if by_pipe:
            return self._one_by_one(numbers, by_pipe)
        if whole:
            return self._merge_whole()
        envs = np.concatenate(
            [np.arange(s.start, s.stop) for s in map(self.slices.__getitem__, numbers)]
        )
        kinds = self.table[self.worker_of[envs], self.kinds[envs]]
        return self._merge(kinds, self.infos[envs], cache=False)

    def _merge_whole(self) -> dict[str, Any]:
        """The infos of every env, from the records."""
        common = self._common()
        if common is not None:  # one signature in every env: no numbers to look up
            return self._merge_alike(common)
        return self._merge(self.table[self.worker_of, self.kinds], self.infos, cache=True)

    def _merge(self, numbers: np.ndarray, rows: np.ndarray, cache: bool) -> dict[str, Any]:
        """The infos of the records ``rows``, env ``i``'s of signature ``numbers[i]``."""
        listed = numbers.tolist()  # one call; counting a list costs less than numpy's ==
        first = listed[0]
        if listed.count(first) == len(listed):
            order: tuple[int, ...] = (first,)
        else:
            order = tuple(dict.fromkeys(listed))
        plan = self._plan(order) if cache else Plan.of(self._numbered(order), rows)
        if plan is None:  # a key of two types: as merge_infos merges them
            infos = [self._info(n, row) for n, row in zip(listed, rows, strict=True)]
            return merge_infos(infos, len(infos))
        return plan.merge(numbers)

    def _common(self) -> int | None:
        """The one signature of every env's info, if the workers all wrote one."""
        if self.uniform is None:
            return None
        common = None
        for worker, local in enumerate(self.uniform.tolist()):
            if local < 0:
                return None
            number = self.known[worker][local]
            if common is None:
                common = number
            elif number != common:
                return None
        return common

    def _merge_alike(self, number: int) -> dict[str, Any]:
        """The infos of every env, all of signature ``number``."""
        plan = self._plan((number,))
        assert plan is not None  # one signature: one type per key
        return plan.merge_alike(len(self.infos))

    def _plan(self, order: tuple[int, ...]) -> Plan | None:
        """The kept plan for the whole batch's records of signatures ``order``."""
        if order in self.plans:
            return self.plans[order]
        if len(self.plans) >= MAX_PLANS:  # envs whose infos take many shapes
            self.plans.clear()
        plan = self.plans[order] = Plan.of(self._numbered(order), self.infos)
        return plan

    def _numbered(self, order: tuple[int, ...]) -> list[tuple[int, Signature]]:
        return [(n, self.signatures[n]) for n in order]

    def _info(self, number: int, row: np.ndarray) -> dict[str, Any]:
        """The info written into ``row`` (uint8) with signature ``number``."""
        return unflatten(self.signatures[number], records(row[None], self.dtypes[number])[0])

    def _one_by_one(
        self, numbers: list[int], by_pipe: dict[int, list[dict[str, Any]]]
    ) -> dict[str, Any]:
        infos: list[dict[str, Any]] = []
        for number in numbers:
            if number in by_pipe:
                infos.extend(by_pipe[number])
                continue
            span = self.slices[number]
            kinds = self.table[number, self.kinds[span]]
            for n, row in zip(kinds.tolist(), self.infos[span], strict=True):
                infos.append(self._info(n, row))
        return merge_infos(infos, len(infos))

    def _announce(self, number: int, fresh: list[Signature]) -> None:
        """Number worker ``number``'s new signatures (the same number for equal ones)."""
        for signature in fresh:
            common = self.numbers.get(signature)
            if common is None:
                common = self.numbers[signature] = len(self.signatures)
                self.signatures.append(signature)
                dtype = record_dtype(signature)
                assert dtype is not None  # the worker checked it
                self.dtypes.append(dtype)
            self.known[number].append(common)
        width = max(map(len, self.known))
        self.table = np.array([k + [-1] * (width - len(k)) for k in self.known], np.int64)
