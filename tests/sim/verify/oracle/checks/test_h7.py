"""H7's check alone: a stop slows the robot by the requirement's deceleration while any brake
can work."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h7 import BrakeFacts, Braking, check_h7
from bywire.sim.verify.oracle.invariants import Invariant
from bywire.sim.verify.oracle.requirements import BRAKE_REACT_S, REGEN_WINDOW_S, REQUIRED_DECEL_MPS2
from tests.sim.verify.oracle.checks.shown import STOPPED

BRAKES = BrakeFacts(ebrake_failed=False, hydrobrake_failed=False, drive_healthy=True)
ROLLING = replace(STOPPED, speed_mps=2.0)


def _slowed(seconds: float) -> float:
    return 2.0 + 0.05 - REQUIRED_DECEL_MPS2 * (seconds - BRAKE_REACT_S)


def test_a_stop_begins_when_the_e_brake_engages_with_the_robot_rolling() -> None:
    assert check_h7(None, ROLLING, BRAKES, 1.0) == (Braking(1.0, 2.0, 0.0, 1.0), None)
    assert check_h7(Braking(1.0, 2.0), replace(ROLLING, released=True), BRAKES, 1.1) == (None, None)
    assert check_h7(Braking(1.0, 2.0), replace(ROLLING, speed_mps=0.05), BRAKES, 1.1) == (
        None,
        None,
    )


def test_a_robot_that_slows_too_little_is_flagged_and_judged_afresh_from_there() -> None:
    braking = Braking(1.0, 2.0, 0.0, 1.0)
    slow_enough = replace(ROLLING, speed_mps=_slowed(0.5) - 0.01)
    braking_on, found = check_h7(braking, slow_enough, BRAKES, 1.5)
    assert found is None
    assert braking_on == Braking(1.0, 2.0, 0.5, 1.5)
    too_fast = replace(ROLLING, speed_mps=_slowed(0.5) + 0.01)
    afresh, found = check_h7(braking, too_fast, BRAKES, 1.5)
    assert found is not None
    assert found.invariant is Invariant.H7
    assert found.expected["speed_max_mps"] == _slowed(0.5)
    assert afresh == Braking(1.5, too_fast.speed_mps, 0.0, 1.5)


def test_rolling_backwards_is_bounded_from_below() -> None:
    found = check_h7(Braking(1.0, 2.0, 0.0, 1.0), replace(ROLLING, speed_mps=-2.0), BRAKES, 1.5)[1]
    assert found is not None
    assert found.expected["speed_min_mps"] == -_slowed(0.5)


def test_with_both_friction_brakes_failed_only_a_healthy_drive_s_regeneration_counts() -> None:
    failed = replace(BRAKES, ebrake_failed=True, hydrobrake_failed=True)
    slowing = replace(ROLLING, speed_mps=1.5)
    in_window = check_h7(Braking(1.0, 2.0, 0.0, 1.0), slowing, failed, 1.5)[0]
    assert in_window == Braking(1.0, 2.0, 0.5, 1.5)
    later_s = 1.0 + REGEN_WINDOW_S + 0.5
    past_window = check_h7(Braking(1.0, 2.0, 0.0, later_s - 0.5), slowing, failed, later_s)[0]
    assert past_window == Braking(1.0, 2.0, 0.0, later_s)
    unhealthy = replace(failed, drive_healthy=False)
    assert check_h7(Braking(1.0, 2.0, 0.0, 1.0), slowing, unhealthy, 1.5)[0] == Braking(
        1.0, 2.0, 0.0, 1.5
    )
