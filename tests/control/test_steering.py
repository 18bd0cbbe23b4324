"""Steering: pulse mapping, rate limit and the boosted set-point of §5.1.2."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.steering import (
    SteeringConfig,
    SteeringState,
    pulse_for_steering,
    steering_step,
)

DEFAULT = SteeringConfig()


@pytest.mark.parametrize(
    ("steering_norm", "pulse_s"),
    [(-1.0, 0.0010), (-0.5, 0.00125), (0.0, 0.0015), (0.5, 0.00175), (1.0, 0.0020)],
)
def test_pulse_spans_one_to_two_milliseconds(steering_norm: float, pulse_s: float) -> None:
    assert pulse_for_steering(steering_norm, DEFAULT) == pytest.approx(pulse_s)


def test_asymmetric_calibration_keeps_centre_and_ends() -> None:
    config = SteeringConfig(min_pulse_s=0.0011, center_pulse_s=0.0014, max_pulse_s=0.0019)
    assert pulse_for_steering(-1.0, config) == pytest.approx(0.0011)
    assert pulse_for_steering(0.0, config) == pytest.approx(0.0014)
    assert pulse_for_steering(1.0, config) == pytest.approx(0.0019)
    assert pulse_for_steering(0.5, config) == pytest.approx(0.00165)


def test_reverse_mirrors_the_servo() -> None:
    config = SteeringConfig(reverse=True)
    assert pulse_for_steering(1.0, config) == pytest.approx(0.0010)
    assert pulse_for_steering(-1.0, config) == pytest.approx(0.0020)


@pytest.mark.parametrize(
    ("steering_norm", "pulse_s"), [(5.0, 0.002), (-7.0, 0.001), (math.nan, 0.0015)]
)
def test_out_of_range_and_nan_are_clamped(steering_norm: float, pulse_s: float) -> None:
    assert pulse_for_steering(steering_norm, DEFAULT) == pytest.approx(pulse_s)


def test_rate_limit_bounds_the_change_per_second() -> None:
    config = SteeringConfig(rate_limit_norm_per_s=2.0)
    state, _ = steering_step(SteeringState(), 0.0, now=0.0, config=config)
    state, pulse_s = steering_step(state, 1.0, now=0.1, config=config)
    assert state.setpoint_norm == pytest.approx(0.2)
    assert pulse_s == pytest.approx(pulse_for_steering(0.2, config))
    for tick in range(2, 12):
        state, pulse_s = steering_step(state, 1.0, now=tick * 0.1, config=config)
    assert state.setpoint_norm == pytest.approx(1.0)
    assert pulse_s == pytest.approx(0.002)


def test_boost_adds_the_error_between_set_and_measured_value() -> None:
    config = SteeringConfig(boost_gain=1.0, rate_limit_norm_per_s=100.0)
    state = SteeringState(setpoint_norm=0.3, estimate_norm=0.0, updated_at=0.0)
    state, pulse_s = steering_step(state, 0.3, now=0.01, config=config, measured_norm=0.1)
    # set 0.3, current 0.1: boosted set-point 0.3 + (0.3 − 0.1) = 0.5
    assert pulse_s == pytest.approx(pulse_for_steering(0.5, config))


def test_boost_without_encoder_uses_the_modelled_servo_and_fades_out() -> None:
    config = SteeringConfig(boost_gain=1.0, rate_limit_norm_per_s=100.0, servo_speed_norm_per_s=1.0)
    state, first_pulse_s = steering_step(
        SteeringState(updated_at=0.0), 0.4, now=0.01, config=config
    )
    assert first_pulse_s == pytest.approx(pulse_for_steering(0.8, config))
    for tick in range(2, 200):
        state, pulse_s = steering_step(state, 0.4, now=tick * 0.01, config=config)
    assert pulse_s == pytest.approx(pulse_for_steering(0.4, config))


@given(st.lists(st.floats(-3.0, 3.0) | st.just(math.nan), min_size=1, max_size=50))
def test_pulse_always_within_calibration(targets: list[float]) -> None:
    config = SteeringConfig(boost_gain=2.0)
    state = SteeringState()
    for tick, target in enumerate(targets):
        state, pulse_s = steering_step(state, target, now=tick * 0.01, config=config)
        assert config.min_pulse_s <= pulse_s <= config.max_pulse_s


# Tests added after mutation testing (docs/mutation.md). Steering slew from the first step and far
# from time zero.


def test_the_first_step_has_no_elapsed_time_so_the_set_point_does_not_move() -> None:
    state, pulse_s = steering_step(SteeringState(), 1.0, 100.0, DEFAULT)
    assert state.setpoint_norm == 0.0
    assert pulse_s == pytest.approx(0.0015)


def test_the_rate_limit_uses_the_time_since_the_last_step_late_in_a_run() -> None:
    state = SteeringState(updated_at=100.0)
    state, _ = steering_step(state, 1.0, 100.01, DEFAULT)
    assert state.setpoint_norm == pytest.approx(0.04)
