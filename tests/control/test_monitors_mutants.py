"""Monitors at their exact edges: configuration messages, the slow-servo model's "strictly
ahead" rule on ties, and both faults raised together."""

from __future__ import annotations

import math

import pytest

from bywire.control.error_flags import ErrorFlag
from bywire.control.monitors import MonitorConfig, MonitorInputs, MonitorState, monitor_step

CONFIG = MonitorConfig()


def test_a_slow_servo_speed_below_one_per_second_is_a_valid_setting() -> None:
    assert MonitorConfig(servo_speed_norm_per_s=0.5).servo_speed_norm_per_s == 0.5


def test_a_negative_threshold_is_refused_with_a_message_saying_what_is_wrong() -> None:
    with pytest.raises(ValueError, match=r"^monitor thresholds must be finite and >= 0$"):
        MonitorConfig(steering_margin_s=-1.0)


def test_a_bad_servo_speed_is_refused_with_a_message_naming_it() -> None:
    with pytest.raises(ValueError, match=r"^servo_speed_norm_per_s must be finite and > 0$"):
        MonitorConfig(servo_speed_norm_per_s=0.0)


def _model_after(model: float, target: float, command: float, measured: float) -> float | None:
    """Where the servo model stands after one step taking no time (so only the pull counts)."""
    state = MonitorState(servo_model_norm=model, servo_target_norm=target, updated_at=1.0)
    inputs = MonitorInputs(steering_command_norm=command, steering_measured_norm=measured)
    new_state, _ = monitor_step(state, inputs, 1.0, CONFIG)
    return new_state.servo_model_norm


def test_a_reading_strictly_closer_to_the_new_command_pulls_the_model_to_it() -> None:
    # last target 0, model still there; the command is now 0.5 and the servo is already at 0.25
    assert _model_after(model=0.0, target=0.0, command=0.5, measured=0.25) == 0.25


def test_a_reading_only_as_close_to_the_new_command_as_the_model_does_not_pull_it() -> None:
    # model at the last target 0.5; the command is 0.25; the reading 0.0 is 0.25 away as well
    assert _model_after(model=0.5, target=0.5, command=0.25, measured=0.0) == 0.5


def test_a_reading_only_as_close_to_the_last_target_as_the_model_does_not_pull_it() -> None:
    # last target 0.5, model short of it at 0.25, the reading 0.75 as far beyond it
    assert _model_after(model=0.25, target=0.5, command=0.25, measured=0.75) == 0.25


def test_a_servo_stuck_beyond_its_target_is_late_once_the_model_is_within_tolerance() -> None:
    state = MonitorState(servo_model_norm=0.25, servo_target_norm=0.5, updated_at=1.0)
    stuck = MonitorInputs(steering_command_norm=0.25, steering_measured_norm=0.75)
    state, first = monitor_step(state, stuck, 1.0, CONFIG)
    assert state.steering_late_since == 1.0
    _, later = monitor_step(state, stuck, 1.25, CONFIG)
    assert first == ErrorFlag(0)
    assert later == ErrorFlag.STEERING_ENCODER_FAULT


def test_a_pressure_fault_and_an_encoder_fault_are_raised_together() -> None:
    broken = MonitorInputs(hydro_duty=1.0, pressure_bar=0.0, steering_measured_norm=math.nan)
    state, _ = monitor_step(MonitorState(), broken, 0.0, CONFIG)
    _, flags = monitor_step(state, broken, 1.0, CONFIG)
    assert flags == ErrorFlag.HYDRO_PRESSURE_FAULT | ErrorFlag.STEERING_ENCODER_FAULT
