"""Behaviour is kept bit for bit: 300 seeded steps of every shipped env hash as recorded.

A mismatch names the stream that changed (observations, rewards, terminated, truncated,
infos, frames). After an intended change, re-record: ``python tests/golden/record.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import pytest
from golden.record import cases, path_of, run

CASES = cases()


PIXEL_STREAMS = {"observations", "frames"}
RECORDED_WITH_CV2 = 5  # cv2's major version of the recordings: 4.x warps and writes otherwise


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden_hashes_unchanged(name):
    expected = json.loads(path_of(name).read_text())
    got = run(CASES[name])
    changed = {k for k in expected["sha256"] if got["sha256"].get(k) != expected["sha256"][k]}
    hint = ""
    if changed and changed <= PIXEL_STREAMS and _cv2_major() < RECORDED_WITH_CV2:
        hint = (
            f" (cv2 {cv2.__version__}: the pixels were recorded with opencv {RECORDED_WITH_CV2},"
            " whose warp rounds and whose fonts draw differently; the test extra installs it)"
        )
    assert got == expected, f"{name}: {sorted(changed) or 'counts'} changed{hint}"


def _cv2_major() -> int:
    return int(cv2.__version__.split(".")[0])


def test_every_case_has_a_recording():
    recorded = {p.stem for p in path_of("x").parent.glob("*.json")}
    assert recorded == set(CASES)


def test_hashes_do_not_depend_on_numpys_simd_dispatch():
    """numpy picks its SIMD kernels by CPU, and its AVX-512 arctan2, sin and cos may differ
    from the AVX2 ones in the last bit: a track built from them would start a car a bit
    differently on another machine. Every case, with numpy held to its baseline kernels in a
    fresh interpreter, hashes as recorded (on a baseline-only CPU this is the plain run)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    dispatched = " ".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f))
    script = (
        "import json, sys\n"
        "from golden.record import cases, path_of, run\n"
        "changed = [n for n, make in sorted(cases().items())\n"
        "           if run(make) != json.loads(path_of(n).read_text())]\n"
        "print(json.dumps(changed))\n"
    )
    tests = Path(__file__).resolve().parent
    environment = {**os.environ, "NPY_DISABLE_CPU_FEATURES": dispatched}
    environment["PYTHONPATH"] = os.pathsep.join(
        filter(None, [str(tests), environment.get("PYTHONPATH")])
    )
    done = subprocess.run(
        [sys.executable, "-c", script], env=environment, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.splitlines()[-1]) == [], f"numpy without {dispatched}"
