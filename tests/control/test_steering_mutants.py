"""Steering slew from the first step and far from time zero."""

from __future__ import annotations

import pytest

from bywire.control.steering import SteeringConfig, SteeringState, steering_step

CONFIG = SteeringConfig()  # 4 /s rate limit, 1…2 ms pulses


def test_the_first_step_has_no_elapsed_time_so_the_set_point_does_not_move() -> None:
    state, pulse_s = steering_step(SteeringState(), 1.0, 100.0, CONFIG)
    assert state.setpoint_norm == 0.0
    assert pulse_s == pytest.approx(0.0015)


def test_the_rate_limit_uses_the_time_since_the_last_step_late_in_a_run() -> None:
    state = SteeringState(updated_at=100.0)
    state, _ = steering_step(state, 1.0, 100.01, CONFIG)
    assert state.setpoint_norm == pytest.approx(0.04)
