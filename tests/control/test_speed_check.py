"""The wheel-speed sensor's plausibility: a dead sensor is caught and no longer trusted."""

from __future__ import annotations

import math
from collections.abc import Sequence

from bywire.control.interlocks import InterlockConfig
from bywire.control.speed_check import (
    SpeedCheckState,
    cleared,
    speed_check_step,
    trusted_speed,
)

CONFIG = InterlockConfig()


def readings(speeds: Sequence[float | None], throttle: float = 0.0) -> SpeedCheckState:
    state = SpeedCheckState()
    for index, speed in enumerate(speeds):
        state = speed_check_step(state, speed, throttle, index * 0.01, CONFIG)
    return state


def test_a_sensor_that_drops_to_zero_at_speed_is_faulted_and_not_trusted() -> None:
    """Hazard row 10: 1.9 m/s, then 0 within 10 ms: no brake stops the robot that fast."""
    state = readings([1.9, 1.9, 0.0])
    assert state.faulted
    assert trusted_speed(state, 0.0) is None


def test_hard_braking_is_plausible() -> None:
    decelerating = [max(2.0 - 0.12 * index, 0.0) for index in range(30)]  # 12 m/s²
    assert not readings(decelerating).faulted


def test_a_sensor_at_standstill_while_the_robot_is_driven_is_faulted_after_the_time() -> None:
    steps = int(CONFIG.speed_stuck_s / 0.01)
    assert not readings([0.0] * steps, throttle=0.5).faulted
    assert readings([0.0] * (steps + 2), throttle=0.5).faulted
    assert not readings([0.0] * (steps + 2), throttle=0.1).faulted  # not driven hard enough


def test_the_fault_holds_until_cleared_by_an_arming_event() -> None:
    state = readings([1.9, 0.0, 0.0, 0.0])
    assert speed_check_step(state, 0.0, 0.0, 1.0, CONFIG).faulted
    assert speed_check_step(state, None, 0.0, 1.0, CONFIG).faulted
    assert not cleared(state).faulted
    assert trusted_speed(cleared(state), 0.0) == 0.0


def test_a_non_finite_reading_is_a_fault() -> None:
    assert readings([math.nan]).faulted
