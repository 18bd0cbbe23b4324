"""H4's check alone: no throttle against the direction the robot really moves."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h4 import MotionFacts, check_h4
from bywire.sim.verify.oracle.invariants import Invariant
from tests.sim.verify.oracle.checks.shown import DRIVING

SENSED = MotionFacts(
    sensor_dead=False,
    died_at_mps=0.0,
    brake_failed=False,
    standstill_mps=0.05,
    unnoticed_death_mps=0.45,
)
REVERSING = replace(DRIVING, forward=False, reverse=True)


def test_reverse_while_rolling_forward_and_forward_while_rolling_back_are_flagged() -> None:
    found = check_h4(replace(REVERSING, speed_mps=0.3), SENSED, 1.0)
    assert found is not None
    assert (found.invariant, found.detail) == (Invariant.H4, "driven reverse at 0.30 m/s")
    assert check_h4(replace(DRIVING, speed_mps=-0.3), SENSED, 1.0) is not None


def test_below_the_standstill_threshold_without_throttle_or_enable_nothing_is_flagged() -> None:
    assert check_h4(replace(REVERSING, speed_mps=0.05), SENSED, 1.0) is None
    assert check_h4(replace(REVERSING, speed_mps=0.3, throttle_volts=0.0), SENSED, 1.0) is None
    assert check_h4(replace(REVERSING, speed_mps=0.3, enable=False), SENSED, 1.0) is None
    assert check_h4(replace(DRIVING, speed_mps=0.3), SENSED, 1.0) is None  # with the motion


def test_a_sensor_that_died_unnoticed_holds_the_robot_to_the_speed_it_died_at() -> None:
    died = replace(SENSED, sensor_dead=True, died_at_mps=0.4)
    assert check_h4(replace(REVERSING, speed_mps=0.39), died, 1.0) is None
    assert check_h4(replace(REVERSING, speed_mps=0.41), died, 1.0) is not None
    noticed = replace(died, died_at_mps=1.5)  # noticed: the threshold is the usual one
    assert check_h4(replace(REVERSING, speed_mps=0.3), noticed, 1.0) is not None


def test_a_dead_sensor_with_a_failed_hydraulic_brake_is_a_double_fault_left_alone() -> None:
    double = replace(SENSED, sensor_dead=True, died_at_mps=1.5, brake_failed=True)
    assert check_h4(replace(REVERSING, speed_mps=1.0), double, 1.0) is None
    assert check_h4(replace(REVERSING, speed_mps=1.0), replace(SENSED, brake_failed=True), 1.0)
