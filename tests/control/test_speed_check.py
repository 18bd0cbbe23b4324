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


def test_a_cleared_fault_is_trusted_again_only_once_the_sensor_reads_motion() -> None:
    """Armed again while still rolling, a dead sensor's standstill must not count."""
    state = cleared(readings([1.9, 0.0, 0.0, 0.0]))
    for step in range(200):  # two seconds of standstill readings, no throttle
        state = speed_check_step(state, 0.0, 0.0, 1.0 + step * 0.01, CONFIG)
        assert trusted_speed(state, 0.0) is None
    state = speed_check_step(state, 0.2, 0.0, 3.0, CONFIG)  # it shows motion: it works
    assert trusted_speed(state, 0.2) == 0.2
    assert trusted_speed(speed_check_step(state, 0.0, 0.0, 4.0, CONFIG), 0.0) == 0.0


def test_a_standstill_read_after_throttle_is_unproven_until_the_sensor_reads_motion() -> None:
    """A sensor dead from power-up, driven for less than the stuck time: not a fault, but its
    standstill proves nothing; a working one proves it within a reading."""
    dead = readings([0.0] * 50, throttle=0.5)
    assert not dead.faulted
    assert trusted_speed(speed_check_step(dead, 0.0, 0.0, 1.0, CONFIG), 0.0) is None
    working = readings([0.0, 0.0, 0.1, 0.3, 0.5], throttle=0.5)
    assert trusted_speed(working, 0.5) == 0.5
    braked = speed_check_step(working, 0.0, 0.0, 0.2, CONFIG)
    assert trusted_speed(braked, 0.0) == 0.0  # braked to standstill with no throttle: proven


def test_a_gap_in_the_readings_leaves_the_standstill_unproven() -> None:
    state = speed_check_step(readings([0.0, 0.0]), None, 0.0, 0.1, CONFIG)
    assert trusted_speed(speed_check_step(state, 0.0, 0.0, 0.2, CONFIG), 0.0) is None
    assert trusted_speed(readings([0.0] * 20), 0.0) == 0.0  # power-up at rest: trusted


def test_a_non_finite_reading_is_a_fault() -> None:
    assert readings([math.nan]).faulted
