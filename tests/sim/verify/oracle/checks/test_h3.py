"""H3's check alone: after a watchdog trip the drive stays off and the steering where it was."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h3 import TRIP_SETTLE_S, TripFacts, check_h3
from bywire.sim.verify.oracle.checks.hold import SteeringHold
from bywire.sim.verify.oracle.invariants import Invariant
from tests.sim.verify.oracle.checks.shown import STOPPED

TRIPPED = TripFacts(tripped_at=1.0, dac_unsure=False, boosted=False)


def test_nothing_is_judged_without_a_trip_or_in_the_trip_s_own_pass() -> None:
    enabled = replace(STOPPED, enable=True)
    assert check_h3(SteeringHold(), enabled, replace(TRIPPED, tripped_at=None), 2.0)[1] is None
    hold, found = check_h3(SteeringHold(), enabled, TRIPPED, 1.0 + TRIP_SETTLE_S - 0.001)
    assert (hold, found) == (SteeringHold(), None)


def test_an_enable_line_high_after_the_trip_is_flagged() -> None:
    hold, found = check_h3(SteeringHold(), replace(STOPPED, enable=True), TRIPPED, 1.1)
    assert found is not None
    assert found.invariant is Invariant.H3
    assert found.expected["motors_enabled"] is False
    assert found.expected["steering_held_since_s"] == hold.from_s == 1.1


def test_the_steering_must_stay_where_it_was_unless_boosted() -> None:
    hold, found = check_h3(SteeringHold(), STOPPED, TRIPPED, 1.1)
    assert found is None
    turned = replace(STOPPED, steering_pulse_s=0.0017)
    assert check_h3(hold, turned, TRIPPED, 1.2)[1] is not None
    assert check_h3(hold, turned, replace(TRIPPED, boosted=True), 1.2)[1] is None


def test_throttle_volts_a_failing_dac_holds_are_left_to_the_enable_line() -> None:
    stuck = replace(STOPPED, throttle_volts=1.0)
    assert check_h3(SteeringHold(), stuck, TRIPPED, 1.1)[1] is not None
    assert check_h3(SteeringHold(), stuck, replace(TRIPPED, dac_unsure=True), 1.1)[1] is None
