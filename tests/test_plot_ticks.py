"""The report's charts label their value axes at round numbers that cover the data."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.experiment import plots

ROUND_MANTISSAS = (1.0, 2.0, 2.5, 5.0, 10.0)  # 10: a power of ten seen from just below


def is_round(step: float) -> bool:
    mantissa = step / 10.0 ** math.floor(math.log10(step))
    return any(abs(mantissa - m) < 1e-6 * m for m in ROUND_MANTISSAS)


def tolerance(ticks: tuple[float, ...]) -> float:
    """Rounding of k x step at the ticks' magnitude."""
    return 1e-9 * max(abs(t) for t in ticks) + 1e-300


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=examples(500), deadline=None)
@given(finite, st.floats(1e-6, 1e6), st.integers(3, 9))
def test_ticks_are_round_evenly_spaced_and_cover_the_range(low: float, span: float, most: int):
    assume(span >= 1e-6 * abs(low))  # a chart's values: not a millionth apart at their size
    high = low + span
    ticks = plots.nice_ticks(low, high, most)
    assert 2 <= len(ticks) <= most
    assert ticks[0] <= low and ticks[-1] >= high
    steps = np.diff(ticks)
    step = float(np.median(steps))
    assert np.allclose(steps, step, rtol=0, atol=tolerance(ticks))
    assert is_round(step)
    # multiples of the step, and not a step more than needed at either end
    assert all(abs(t - step * round(t / step)) <= tolerance(ticks) for t in ticks)
    assert ticks[1] > low and ticks[-2] < high


@pytest.mark.parametrize(
    ("low", "high", "expected"),
    [
        (-0.379, 0.384, ["-0.4", "-0.2", "0.0", "0.2", "0.4"]),  # a steering trace
        (0.0, 104.6, ["0", "25", "50", "75", "100", "125"]),  # a speed trace
        (0.0012, 0.0047, ["0.001", "0.002", "0.003", "0.004", "0.005"]),
        (-250.0, 1000.0, ["-250", "0", "250", "500", "750", "1000"]),
        (0.0, 1.1, ["0.00", "0.25", "0.50", "0.75", "1.00", "1.25"]),
    ],
)
def test_tick_labels_read_as_round_numbers(low: float, high: float, expected: list[str]):
    assert plots.tick_labels(plots.nice_ticks(low, high)) == expected


@settings(max_examples=examples(300), deadline=None)
@given(finite, st.floats(1e-6, 1e6))
def test_labels_are_distinct_and_read_back_as_the_ticks(low: float, span: float):
    assume(span >= 1e-6 * abs(low))
    ticks = plots.nice_ticks(low, low + span)
    labels = plots.tick_labels(ticks)
    assert len(set(labels)) == len(labels)
    assert not any(label.startswith("-0") and float(label) == 0 for label in labels)
    step = ticks[1] - ticks[0]
    assert all(
        abs(float(label) - t) <= step * 1e-6 + tolerance(ticks)
        for label, t in zip(labels, ticks, strict=True)
    )


def test_ticks_cover_a_range_that_rounding_would_miss():
    # 27 + 1e-6 is no float multiple of the step (2.5e-7): ceil(high / step) x step
    # rounds just below it, so one more step is taken
    low, high = 27.0, 27.000001
    ticks = plots.nice_ticks(low, high)
    assert ticks[0] <= low and ticks[-1] >= high


def test_value_axis_ends_on_its_ticks_and_holds_the_data():
    values = np.array([np.nan, -0.344, 0.0, 0.349])
    (low, high), ticks = plots.value_axis(values, include_zero=True)
    assert (low, high) == (ticks[0], ticks[-1])
    assert low <= -0.344 and high >= 0.349


def test_a_panel_without_data_has_no_value_labels():
    t = np.linspace(0.0, 10.0, 50)
    empty = plots.time_series(t, [("cross-track error", np.full(50, np.nan))], "episode")
    measured = plots.time_series(t, [("cross-track error", np.sin(t))], "episode")
    label_column = (slice(40, 175), slice(0, 52))  # left of the plotting area
    assert (empty[label_column] == plots.PAPER).all()
    assert (measured[label_column] != plots.PAPER).any()


def test_a_single_tick_is_printed_plainly():
    assert plots.tick_labels((5.0,)) == ["5"]
    assert plots.tick_labels(()) == []
