"""Pure vehicle model: drive needs enable and one direction, brakes never reverse, turns."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.hal.simulated.vehicle_model import (
    ActuatorInputs,
    VehicleConfig,
    VehicleModel,
    VehicleState,
    servo_target_norm,
    speed_step,
)

MODEL = VehicleModel()
STEP_S = 0.005
FULL_FORWARD = ActuatorInputs(
    throttle_volts=5.0,
    motors_enable=True,
    motors_forward=True,
    ebrake_release=True,
    steering_pulse_s=0.0015,
)


def run(state: VehicleState, inputs: ActuatorInputs, duration_s: float) -> VehicleState:
    for _ in range(round(duration_s / STEP_S)):
        state = MODEL.step(state, inputs, STEP_S)
    return state


def test_full_throttle_forward_accelerates_towards_top_speed() -> None:
    after_1_s = run(VehicleState(), FULL_FORWARD, 1.0)
    after_20_s = run(after_1_s, FULL_FORWARD, 19.0)
    assert 0.5 < after_1_s.speed_mps < 1.2
    assert after_1_s.speed_mps < after_20_s.speed_mps < MODEL.config.top_speed_mps
    assert after_20_s.speed_mps == pytest.approx(MODEL.config.top_speed_mps, rel=0.01)
    assert after_20_s.x_m > 30.0
    assert after_20_s.y_m == pytest.approx(0.0, abs=1e-9)
    assert after_20_s.distance_m == pytest.approx(after_20_s.x_m)


@pytest.mark.parametrize(
    "inputs",
    [
        dataclasses.replace(FULL_FORWARD, motors_enable=False),
        dataclasses.replace(FULL_FORWARD, motors_forward=False),
        # both direction lines: the controller refuses to drive
        dataclasses.replace(FULL_FORWARD, motors_reverse=True),
        dataclasses.replace(FULL_FORWARD, throttle_volts=0.0),
    ],
    ids=["not-enabled", "no-direction", "both-directions", "no-throttle"],
)
def test_no_drive_without_enable_and_exactly_one_direction(inputs: ActuatorInputs) -> None:
    assert run(VehicleState(), inputs, 2.0).speed_mps == 0.0


def test_config_refuses_a_drive_weaker_than_rolling_drag() -> None:
    with pytest.raises(ValueError, match="rolling_drag"):
        VehicleConfig(max_drive_accel_mps2=0.1)


def test_reverse_gives_negative_speed_up_to_the_reverse_top_speed() -> None:
    reverse = dataclasses.replace(FULL_FORWARD, motors_forward=False, motors_reverse=True)
    state = run(VehicleState(), reverse, 20.0)
    assert -MODEL.config.reverse_top_speed_mps < state.speed_mps < -0.8
    assert state.x_m < 0.0
    assert state.distance_m == pytest.approx(-state.x_m)


ROLLING = ActuatorInputs(motors_enable=True, ebrake_release=True)


@pytest.mark.parametrize(
    "inputs",
    [
        dataclasses.replace(ROLLING, regen_volts=5.0),
        dataclasses.replace(ROLLING, hydraulic_duty=1.0),
        dataclasses.replace(ROLLING, ebrake_release=False),
        dataclasses.replace(ROLLING, motors_enable=False),  # coasting: rolling drag alone
    ],
    ids=["regen", "hydraulic", "ebrake", "coast"],
)
@pytest.mark.parametrize("direction", [1, -1])
def test_braking_stops_the_robot_and_never_reverses_it(
    inputs: ActuatorInputs, direction: int
) -> None:
    start = VehicleState(speed_mps=2.0 * direction)
    state = start
    speeds = []
    for _ in range(round(20.0 / STEP_S)):
        state = MODEL.step(state, inputs, STEP_S)
        speeds.append(state.speed_mps)
    assert speeds[-1] == 0.0
    assert all(speed * direction >= 0.0 for speed in speeds)
    assert all(abs(b) <= abs(a) for a, b in itertools.pairwise(speeds))


def test_harder_brakes_stop_sooner() -> None:
    def stopping_time_s(inputs: ActuatorInputs) -> float:
        state, elapsed_s = VehicleState(speed_mps=3.0), 0.0
        while state.speed_mps > 0.0:
            state, elapsed_s = MODEL.step(state, inputs, STEP_S), elapsed_s + STEP_S
        return elapsed_s

    released = ActuatorInputs(motors_enable=True, ebrake_release=True)
    coast = stopping_time_s(released)
    regen = stopping_time_s(dataclasses.replace(released, regen_volts=5.0))
    hydraulic = stopping_time_s(dataclasses.replace(released, regen_volts=5.0, hydraulic_duty=1.0))
    assert coast > regen > hydraulic
    assert coast == pytest.approx(3.0 / MODEL.config.rolling_drag_mps2, abs=0.01)


def test_engaged_ebrake_holds_the_robot_against_full_throttle() -> None:
    inputs = dataclasses.replace(FULL_FORWARD, ebrake_release=False)
    assert run(VehicleState(), inputs, 5.0).speed_mps == 0.0
    moving = run(VehicleState(speed_mps=2.5), inputs, 2.0)
    assert moving.speed_mps == 0.0


@given(st.floats(-3.0, 3.0), st.floats(-2.0, 2.0), st.floats(0.0, 10.0), st.floats(1e-4, 0.05))
def test_resistance_at_least_the_drive_never_reverses_or_speeds_up(
    speed_mps: float, drive_mps2: float, extra_resistance: float, dt_s: float
) -> None:
    resistance = abs(drive_mps2) + extra_resistance
    new_speed_mps = speed_step(speed_mps, drive_mps2, resistance, dt_s)
    assert new_speed_mps * speed_mps >= 0.0
    assert abs(new_speed_mps) <= abs(speed_mps) + 1e-12


def test_steering_servo_moves_at_its_finite_rate() -> None:
    full_right = dataclasses.replace(FULL_FORWARD, throttle_volts=0.0, steering_pulse_s=0.002)
    state = run(VehicleState(), full_right, 0.2)
    assert state.steering_norm == pytest.approx(0.2 * MODEL.config.servo_rate_norm_per_s)
    state = run(state, full_right, 1.0)
    assert state.steering_norm == pytest.approx(1.0)
    full_left = dataclasses.replace(full_right, steering_pulse_s=0.001)
    state = run(state, full_left, 0.4)
    assert state.steering_norm == pytest.approx(1.0 - 0.4 * 1.5)


@pytest.mark.parametrize(
    ("pulse_s", "norm"),
    [(0.001, -1.0), (0.00125, -0.5), (0.0015, 0.0), (0.00175, 0.5), (0.002, 1.0), (0.0025, 1.0)],
)
def test_servo_pulse_maps_1_to_2_ms_onto_minus_one_to_one(pulse_s: float, norm: float) -> None:
    assert servo_target_norm(pulse_s, 0.3, VehicleConfig()) == pytest.approx(norm)


def test_without_pulses_the_servo_stays_where_it_is() -> None:
    assert servo_target_norm(0.0, 0.3, VehicleConfig()) == 0.3


@pytest.mark.parametrize(("pulse_s", "outer"), [(0.001, "right"), (0.002, "left")])
def test_in_a_turn_the_outer_wheel_runs_faster(pulse_s: float, outer: str) -> None:
    turning = dataclasses.replace(FULL_FORWARD, steering_pulse_s=pulse_s)
    state = run(VehicleState(), turning, 3.0)
    left_mps, right_mps = MODEL.wheel_speeds(state)
    assert (left_mps + right_mps) / 2 == pytest.approx(state.speed_mps)
    assert (right_mps > left_mps) == (outer == "right")
    expected_difference = state.speed_mps * math.tan(math.radians(30)) / 0.8 * 0.6
    assert abs(right_mps - left_mps) == pytest.approx(expected_difference)


def test_a_left_turn_turns_the_heading_counter_clockwise() -> None:
    left = dataclasses.replace(FULL_FORWARD, steering_pulse_s=0.001)
    state = run(VehicleState(), left, 3.0)
    assert state.heading_rad > 0.0
    assert state.y_m > 0.0
    assert state.yaw_rate_radps > 0.0


def test_straight_ahead_wheels_run_at_the_same_speed() -> None:
    state = run(VehicleState(), FULL_FORWARD, 1.0)
    left_mps, right_mps = MODEL.wheel_speeds(state)
    assert left_mps == right_mps == state.speed_mps > 0.0


def _on_grade(
    state: VehicleState, inputs: ActuatorInputs, grade: float, seconds: float
) -> VehicleState:
    for _ in range(round(seconds / STEP_S)):
        state = MODEL.step(state, inputs, STEP_S, grade)
    return state


COASTING = ActuatorInputs(ebrake_release=True, steering_pulse_s=0.0015)


def test_downhill_gravity_carries_the_robot_past_its_top_speed() -> None:
    flat = _on_grade(VehicleState(), FULL_FORWARD, 0.0, 20.0)
    downhill = _on_grade(VehicleState(), FULL_FORWARD, -0.1, 20.0)
    assert flat.speed_mps == pytest.approx(3.0, abs=0.01)
    assert downhill.speed_mps > 3.5
    rolled = _on_grade(VehicleState(), COASTING, -0.1, 1.0)  # nothing driving: it rolls forward
    assert rolled.speed_mps == pytest.approx((9.81 * 0.1 / math.sqrt(1.01) - 0.15) * 1.0, rel=0.01)


def test_uphill_a_coasting_robot_rolls_back_and_brakes_hold_it() -> None:
    assert _on_grade(VehicleState(), COASTING, 0.1, 1.0).speed_mps < -0.5
    held = dataclasses.replace(COASTING, hydraulic_duty=1.0)
    assert _on_grade(VehicleState(), held, 0.1, 1.0).speed_mps == 0.0
    assert _on_grade(VehicleState(), ActuatorInputs(), -0.3, 1.0).speed_mps == 0.0  # e-brake


def test_a_flat_road_is_the_model_without_grades() -> None:
    state = VehicleState(speed_mps=1.3)
    assert MODEL.step(state, FULL_FORWARD, STEP_S, 0.0) == MODEL.step(state, FULL_FORWARD, STEP_S)
