"""Behaviour is kept bit for bit: 300 seeded steps of every shipped env hash as recorded.

A mismatch names the stream that changed (observations, rewards, terminated, truncated,
infos, frames). After an intended change, re-record: ``python tests/golden/record.py``.
"""

from __future__ import annotations

import json

import pytest
from golden.record import cases, path_of, run

CASES = cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden_hashes_unchanged(name):
    expected = json.loads(path_of(name).read_text())
    assert run(CASES[name]) == expected


def test_every_case_has_a_recording():
    recorded = {p.stem for p in path_of("x").parent.glob("*.json")}
    assert recorded == set(CASES)
