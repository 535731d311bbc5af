"""The dynamic car's two tyre-model paths, Python and the compiled numba kernel, give the
same results bit for bit: one car's step over random wheel states, body motions,
controls, time steps and grips (on road or grass per wheel), many cars' steps in one call
against the Python path car by car, ``control``, and CPython's ``math.hypot`` itself.
Also: the path is chosen by ``TINYRACE_PHYSICS``, numba stays unimported until a car
drives, and a pickled car keeps its wheels on its own state array."""

from __future__ import annotations

import math
import os
import pickle
import struct
import subprocess
import sys

import numpy as np
import pymunk
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis_budget import examples

from tinyrace.cars import dynamic_python
from tinyrace.cars.dynamic import DynamicCar, physics_kernel
from tinyrace.cars.dynamic_layout import BRAKE, GAS, OMEGA, PHASE, SKID, STEER, WHEELS
from tinyrace.cars.kernels import dynamic as dynamic_numba

FINITE = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
SOME_ZERO = st.one_of(st.just(0.0), st.just(-0.0), FINITE)  # steer 0: the hull's own axes
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)


def bits(value: float) -> bytes:
    return struct.pack("<d", value)


def same(a: float, b: float) -> bool:
    """Equal bits, or both NaN (a NaN's sign and payload are the hardware's)."""
    return bits(a) == bits(b) or (math.isnan(a) and math.isnan(b))


def same_arrays(a: np.ndarray, b: np.ndarray) -> bool:
    return all(same(x, y) for x, y in zip(a.ravel().tolist(), b.ravel().tolist(), strict=True))


def a_car(scale: float, y_down: bool) -> DynamicCar:
    return DynamicCar.build(pymunk.Space(), (0.0, 0.0, 0.0), scale=scale, y_down=y_down)


@st.composite
def wheel_states(draw: st.DrawFn, cars: int, values: st.SearchStrategy[float]) -> np.ndarray:
    """(FIELDS, 4 cars) wheel states: spins, steering (often 0), gas 0..1, brakes that
    release, brake or lock, phases."""
    state = np.zeros((6, WHEELS * cars))
    size = WHEELS * cars
    state[OMEGA] = draw(st.lists(st.one_of(st.just(0.0), values), min_size=size, max_size=size))
    state[STEER] = draw(st.lists(SOME_ZERO, min_size=size, max_size=size))
    state[GAS] = draw(st.lists(st.floats(0, 1), min_size=size, max_size=size))
    brakes = st.one_of(st.just(0.0), st.floats(0, 1), st.just(0.9))
    state[BRAKE] = draw(st.lists(brakes, min_size=size, max_size=size))
    state[PHASE] = draw(st.lists(FINITE, min_size=size, max_size=size))
    return state


MOTION = st.tuples(st.floats(-7, 7), FINITE, FINITE, FINITE)  # angle, spin, vx, vy
STEP = st.one_of(st.just(1 / 50), st.floats(1e-4, 0.2))  # dt [s]
SCALES = st.sampled_from([(1.0, False), (7.5, True), (0.37, False)])


@settings(max_examples=examples(300), deadline=None)
@given(
    scaled=SCALES,
    state=wheel_states(1, FINITE),
    motion=MOTION,
    dt=STEP,
    target=st.floats(-0.5, 0.5),
    road=st.integers(0, 15),
)
def test_one_car_step_is_the_same_on_both_paths(scaled, state, motion, dt, target, road):
    consts = a_car(*scaled)._consts
    ours, theirs = state.copy(), state.copy()
    expected = dynamic_python.car_forces(ours, consts, dt, *motion, target, road)
    got = dynamic_numba.car_forces(theirs, consts, dt, *motion, target, road)
    assert all(same(a, b) for a, b in zip(expected[:3], got[:3], strict=True)), (expected, got)
    assert expected[3] == got[3]  # the skidding wheels
    assert same_arrays(ours, theirs)


@settings(max_examples=examples(200), deadline=None)
@given(
    state=wheel_states(1, ANY_FLOAT),
    motion=st.tuples(FINITE, ANY_FLOAT, ANY_FLOAT, ANY_FLOAT),
    target=ANY_FLOAT,
    road=st.integers(0, 15),
)
def test_infinities_and_nans_go_the_same_way(state, motion, target, road):
    """Spins, velocities and targets of any float (the angle and steering finite: Python's
    cos raises on infinities, the kernel's gives NaN)."""
    consts = a_car(1.0, False)._consts
    ours, theirs = state.copy(), state.copy()
    expected = dynamic_python.car_forces(ours, consts, 1 / 50, *motion, target, road)
    got = dynamic_numba.car_forces(theirs, consts, 1 / 50, *motion, target, road)
    assert all(same(a, b) for a, b in zip(expected[:3], got[:3], strict=True)), (expected, got)
    assert expected[3] == got[3]
    assert same_arrays(ours, theirs)


@settings(max_examples=examples(60), deadline=None)
@given(
    data=st.data(),
    cars=st.integers(1, 9),
)
def test_many_cars_in_one_call_equal_each_car_alone(data, cars):
    """``batch_forces`` over (FIELDS, 4 n) against ``car_forces`` of the Python path per car."""
    scaled = [data.draw(SCALES) for _ in range(cars)]
    consts = np.column_stack([a_car(*s)._consts for s in scaled])
    state = data.draw(wheel_states(cars, FINITE))
    motion = np.array([data.draw(MOTION) for _ in range(cars)]).T.copy()
    dt = np.array([data.draw(STEP) for _ in range(cars)])
    targets = np.array([data.draw(st.floats(-0.5, 0.5)) for _ in range(cars)])
    on_road = np.array([[data.draw(st.booleans()) for _ in range(WHEELS)] for _ in range(cars)])
    out = np.zeros((3, cars))
    batch = state.copy()
    skidding = dynamic_numba.batch_forces(batch, consts, dt, motion, targets, on_road, out)
    skids = 0
    for row in range(cars):
        alone = state[:, row::cars].copy()
        road = sum(int(on_road[row, w]) << w for w in range(WHEELS))
        *velocity, flags = dynamic_python.car_forces(
            alone, consts[:, row : row + 1], float(dt[row]), *motion[:, row].tolist(),
            float(targets[row]), road,
        )  # fmt: skip
        assert same_arrays(np.array(velocity), out[:, row]), row
        assert same_arrays(alone, batch[:, row::cars]), row
        skids += bin(flags).count("1")
    assert skidding == skids == int(batch[SKID].sum())


@settings(max_examples=examples(100), deadline=None)
@given(
    state=wheel_states(3, FINITE),
    gas=st.lists(st.floats(-1, 2), min_size=3, max_size=3),
    brake=st.lists(st.floats(0, 1), min_size=3, max_size=3),
)
def test_control_is_the_same_on_both_paths(state, gas, brake):
    """The batch's compiled control against each car's own (Python) ``control``."""
    cars = [a_car(1.0, False) for _ in range(3)]
    consts = np.column_stack([car._consts for car in cars])
    theirs = state.copy()
    for row, car in enumerate(cars):
        car.wheel_state[:] = state[:, row::3]
        car.control(0.0, gas[row], brake[row])
    dynamic_numba.batch_control(theirs, consts, np.array(gas), np.array(brake))
    for row, car in enumerate(cars):
        assert same_arrays(car.wheel_state, theirs[:, row::3])


@settings(max_examples=examples(2000), deadline=None)
@given(x=ANY_FLOAT, y=ANY_FLOAT)
def test_compiled_hypot_is_cpythons(x, y):
    assert same(dynamic_numba.compiled_hypot(x, y), math.hypot(x, y)), (x, y)


def test_compiled_hypot_on_subnormals():
    # CPython 3.11 divides subnormals by the larger, 3.12 scales them up first: the two
    # differ in the last bit of a subnormal result (hypothesis found 5.32227073626592e-309)
    rng = np.random.default_rng(4)
    values = rng.uniform(-1, 1, size=(20000, 2)) * 2.2e-308
    values *= 10.0 ** rng.integers(-10, 1, size=(20000, 2))
    for x, y in [(5.32227073626592e-309, 5.32227073626592e-309), *values.tolist()]:
        assert same(dynamic_numba.compiled_hypot(x, y), math.hypot(x, y)), (x, y)


def test_compiled_hypot_on_many_magnitudes():
    rng = np.random.default_rng(3)
    values = rng.normal(size=(20000, 2)) * 10.0 ** rng.integers(-300, 300, size=(20000, 2))
    for x, y in values.tolist():
        assert same(dynamic_numba.compiled_hypot(x, y), math.hypot(x, y)), (x, y)


# -- choosing the path ---------------------------------------------------------------------------
def test_physics_variable_chooses_the_path(monkeypatch):
    monkeypatch.setenv("TINYRACE_PHYSICS", "python")
    assert physics_kernel()[0] == "python"
    monkeypatch.setenv("TINYRACE_PHYSICS", " Numba ")
    assert physics_kernel()[:2] == ("numba", dynamic_numba.car_forces)
    monkeypatch.delenv("TINYRACE_PHYSICS")
    assert physics_kernel()[0] == "numba"  # numba is a test dependency: auto takes it
    with pytest.raises(ValueError, match="auto, numba or python"):
        physics_kernel("fortran")


@pytest.mark.parametrize("path", ["python", "numba"])
def test_a_car_drives_the_same_on_both_paths_and_after_pickling(path, monkeypatch):
    """300 steps with skids, one car per path; a pickled copy halfway goes on the same."""

    def drive(car: DynamicCar, space: pymunk.Space, steps: range) -> list[bytes]:
        rng = np.random.default_rng(steps.start)
        seen = []
        for _ in steps:
            car.control(rng.uniform(-1, 1), rng.uniform(0, 1), rng.choice([0.0, 0.3, 0.95]))
            car.apply_forces(1 / 50, (rng.random(4) < 0.6).tolist())
            space.step(1 / 50)
            seen.append(car.wheel_state.tobytes() + bits(car.body.angular_velocity))
        return seen

    monkeypatch.setenv("TINYRACE_PHYSICS", "python")
    space = pymunk.Space()
    reference = DynamicCar.build(space, (1.0, 2.0, 0.3))
    expected = drive(reference, space, range(150)) + drive(reference, space, range(150, 300))
    monkeypatch.setenv("TINYRACE_PHYSICS", path)
    space = pymunk.Space()
    car = DynamicCar.build(space, (1.0, 2.0, 0.3))
    got = drive(car, space, range(150))
    assert car.kernel == path
    space, car = pickle.loads(pickle.dumps((space, car)))
    assert all(wheel._state is car.wheel_state for wheel in car.wheels)
    got += drive(car, space, range(150, 300))
    assert got == expected
    assert car.skids.lengths.tolist() == reference.skids.lengths.tolist()
    assert car.skids.lengths.sum() > 0  # skid marks were drawn
    assert car.wheels[2].gas == reference.wheels[2].gas > 0  # the wheels read the array


def test_numba_is_imported_when_a_car_first_drives_not_before():
    """Not by ``import tinyrace`` nor ``gym.make``; by the reset (CarRacing's reset drives
    one step with no action, as CarRacing-v3's does)."""
    script = (
        "import sys, gymnasium as gym, tinyrace\n"
        "env = gym.make('tinyrace/CarRacing-v0')\n"
        "print('numba' in sys.modules)\n"
        "env.reset(seed=1)\n"
        "print('numba' in sys.modules, env.unwrapped.car.kernel)\n"
    )
    environ = {**os.environ, "TINYRACE_PHYSICS": "auto"}
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environ, check=True
    )
    assert result.stdout.split() == ["False", "True", "numba"]
