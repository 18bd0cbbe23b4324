"""The speed loop's guarantees, for any inputs: never throttle and brake together, both within
0…1, a direction change at speed only brakes, standstill at a zero target is held, the integral
stays within its limit, and feed-forward alone holds a steady speed."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.model import Gear
from bywire.ros2.settings import BridgeSettings
from bywire.ros2.speed_loop import LoopState, speed_step

SETTINGS = BridgeSettings()
speeds = st.floats(-3.0, 3.0)
gears = st.sampled_from(Gear)
states = st.builds(
    LoopState,
    reference_mps=st.floats(0.0, 3.0),
    integral=st.floats(-0.3, 0.3),
    gear=gears,
)


@given(state=states, target=speeds, measured=speeds, dt=st.floats(0.0, 0.1))
def test_pedals_are_in_range_and_never_both_pressed(
    state: LoopState, target: float, measured: float, dt: float
) -> None:
    after, pedals = speed_step(state, target, measured, dt, SETTINGS)
    assert 0.0 <= pedals.throttle_norm <= 1.0
    assert 0.0 <= pedals.brake_norm <= 1.0
    assert pedals.throttle_norm == 0.0 or pedals.brake_norm == 0.0
    assert abs(after.integral) <= SETTINGS.integral_limit
    assert after.gear is pedals.gear


@given(target=st.floats(0.1, 2.0), measured=st.floats(0.1, 3.0), dt=st.floats(0.0, 0.1))
def test_asked_to_reverse_while_rolling_forward_it_only_brakes(
    target: float, measured: float, dt: float
) -> None:
    state = LoopState(measured, 0.1, Gear.FORWARD)
    after, pedals = speed_step(state, -target, measured, dt, SETTINGS)
    assert pedals.gear is Gear.FORWARD
    assert pedals.throttle_norm == 0.0
    assert after.reference_mps <= state.reference_mps


def test_at_standstill_the_new_direction_is_taken() -> None:
    _, pedals = speed_step(LoopState(0.0, 0.0, Gear.FORWARD), -0.5, 0.0, 0.02, SETTINGS)
    assert pedals.gear is Gear.REVERSE


@given(gear=gears, measured=st.floats(-0.04, 0.04))
def test_a_zero_target_at_standstill_holds_the_brake(gear: Gear, measured: float) -> None:
    state = LoopState(0.0, 0.2, gear)
    after, pedals = speed_step(state, 0.0, measured, 0.02, SETTINGS)
    assert (pedals.throttle_norm, pedals.brake_norm) == (0.0, SETTINGS.hold_brake)
    assert after.integral == 0.0


@pytest.mark.parametrize("speed", [0.5, 1.0, 2.0])
def test_on_target_the_output_is_the_feedforward(speed: float) -> None:
    state = LoopState(speed, 0.0, Gear.FORWARD)
    after, pedals = speed_step(state, speed, speed, 0.02, SETTINGS)
    index = SETTINGS.feedforward_speeds_mps.index(speed)
    assert pedals.throttle_norm == pytest.approx(SETTINGS.feedforward_throttles[index])
    assert after.integral == 0.0


def test_the_reference_rises_no_faster_than_the_acceleration_limit() -> None:
    state = LoopState(0.0, 0.0, Gear.FORWARD)
    after, _ = speed_step(state, 2.0, 1.9, 0.02, SETTINGS)
    assert after.reference_mps == pytest.approx(SETTINGS.accel_limit_mps2 * 0.02)


def test_slower_target_brakes_when_far_too_fast() -> None:
    state = LoopState(1.0, 0.0, Gear.FORWARD)
    _, pedals = speed_step(state, 0.2, 1.5, 0.02, SETTINGS)
    assert pedals.throttle_norm == 0.0
    assert pedals.brake_norm > 0.0
