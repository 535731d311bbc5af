"""The parent's reading of its workers' step answers: infos from the shared records (or
the pipes), exceptions from the pipes."""

from __future__ import annotations

from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from tinyrace.vector import shared
from tinyrace.vector.failures import rebuild_error
from tinyrace.vector.infos import merge_infos


class Answers:
    """Each worker's info signature and its slice's records, as the worker announced them."""

    def __init__(self, infos: np.ndarray, slices: list[slice]) -> None:
        self.infos, self.slices = infos, slices  # infos: (num_envs, INFO_BYTES) uint8
        self.signatures: list[shared.Signature | None] = [None] * len(slices)
        self.records: list[np.ndarray | None] = [None] * len(slices)
        # per worker, its announced signatures in order, with its slice's records of each
        self.known: list[list[tuple[shared.Signature, np.ndarray]]] = [[] for _ in slices]
        self.interned: dict[shared.Signature, shared.Signature] = {}  # equal ones: one object
        # every env's records bound to their signature (when all workers have it), by
        # the interned signature's id (a nested tuple's hash costs more)
        self.whole: dict[int, shared.Bound] = {}

    def collect(
        self, status: np.ndarray, pipes: list[Connection], numbers: list[int] | None = None
    ) -> dict[str, Any]:
        """The step's merged infos of the workers ``numbers`` (default: all), their envs in
        that order: columns of the records when every worker wrote the same kind, else
        each env's info (from its record or the pipe), merged. A worker's exception is
        raised once every worker's answer is read (the pipes stay in step)."""
        numbers = list(range(len(pipes))) if numbers is None else numbers
        per_worker: list[Any] = []
        error: Exception | None = None
        codes = status.tolist()  # one call, not a numpy scalar per worker
        for number in numbers:
            pipe = pipes[number]
            code = codes[number]
            if code == shared.FAILED:
                _, described = pipe.recv()
                error = error or rebuild_error(described, number, self.slices[number])
                per_worker.append(None)
            elif code == shared.INFOS_BY_PIPE:
                per_worker.append(pipe.recv())
            else:
                if code == shared.NEW_SIGNATURE:
                    self._announce(number, pipe.recv())
                else:
                    signature, self.records[number] = self.known[number][code - shared.KNOWN]
                    self.signatures[number] = signature
                per_worker.append(self.signatures[number])
        if error is not None:
            raise error
        first = per_worker[0]
        if isinstance(first, tuple) and per_worker.count(first) == len(per_worker):
            rows = self.records[numbers[0]]
            assert rows is not None
            if len(numbers) == len(pipes):  # every env, in order: one view of all records
                bound = self.whole.get(id(first))
                if bound is None:
                    whole = shared.records(self.infos, rows.dtype)
                    bound = self.whole[id(first)] = shared.bind(first, whole)
                return shared.merge_bound(bound, len(self.infos))
            parts = [self.records[number] for number in numbers]
            return shared.merge_columns(first, np.concatenate(parts))  # type: ignore[arg-type]
        infos: list[dict[str, Any]] = []
        for number, item in zip(numbers, per_worker, strict=True):
            if isinstance(item, list):
                infos.extend(item)
            else:
                records = self.records[number]
                assert records is not None and item is not None
                infos.extend(shared.unflatten(item, row) for row in records)
        return merge_infos(infos, len(infos))

    def _announce(self, number: int, signature: shared.Signature) -> None:
        signature = self.interned.setdefault(signature, signature)
        dtype = shared.record_dtype(signature)
        assert dtype is not None  # the worker checked it
        records = shared.records(self.infos[self.slices[number]], dtype)
        self.signatures[number], self.records[number] = signature, records
        self.known[number].append((signature, records))
