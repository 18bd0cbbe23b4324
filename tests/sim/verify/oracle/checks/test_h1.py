"""H1's check alone: driving is flagged once nothing allows it; a controlled stop may keep the
drive powered within the requirement's bounds, never past them."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h1 import StopFacts, StopWatch, check_h1
from bywire.sim.verify.oracle.invariants import Invariant
from bywire.sim.verify.oracle.requirements import CONTROLLED_STOP_LIMIT_S, STANDSTILL_GRACE_S
from tests.sim.verify.oracle.checks.shown import DRIVING, STOPPED

STOPPING = StopFacts(allowed=False, power_off=False, sensor_untrusted=False, standstill_mps=0.05)
CONTROLLED = replace(STOPPED, enable=True, regen_volts=1.0)
"""A controlled stop: the drive powered, throttle 0 V, regeneration applied, e-brake engaged."""


def test_driving_while_allowed_is_not_judged_and_forgets_the_stop() -> None:
    allowed = replace(STOPPING, allowed=True)
    watch, found = check_h1(StopWatch(1.0, 1.2, True), DRIVING, allowed, 2.0)
    assert (watch, found) == (StopWatch(), None)


def test_driving_in_a_stop_is_flagged_with_the_safe_levels() -> None:
    watch, found = check_h1(StopWatch(), DRIVING, STOPPING, 2.0)
    assert found is not None
    assert found.invariant is Invariant.H1
    assert found.time_s == 2.0
    assert found.expected == {"ebrake_engaged": True, "throttle_volts_max": 0.0}
    assert watch.demand_since == 2.0


def test_the_safe_stop_and_a_controlled_stop_pass() -> None:
    assert check_h1(StopWatch(), STOPPED, STOPPING, 2.0)[1] is None
    assert check_h1(StopWatch(), CONTROLLED, STOPPING, 2.0)[1] is None


def test_an_enable_line_high_without_regeneration_is_no_controlled_stop() -> None:
    unbraked = replace(CONTROLLED, regen_volts=0.0)
    found = check_h1(StopWatch(), unbraked, STOPPING, 2.0)[1]
    assert found is not None
    assert "motors_enabled" not in found.expected  # a controlled stop may still last


def test_a_controlled_stop_may_last_the_requirements_limit_and_no_longer() -> None:
    watch = StopWatch(demand_since=1.0)
    limit_s = 1.0 + CONTROLLED_STOP_LIMIT_S
    assert check_h1(watch, CONTROLLED, STOPPING, limit_s)[1] is None
    found = check_h1(watch, CONTROLLED, STOPPING, limit_s + 0.001)[1]
    assert found is not None
    assert found.expected["motors_enabled"] is False


def test_a_cause_that_makes_the_drive_suspect_allows_no_controlled_stop() -> None:
    found = check_h1(StopWatch(), CONTROLLED, replace(STOPPING, power_off=True), 2.0)[1]
    assert found is not None
    assert found.expected["motors_enabled"] is False


def test_a_standstill_the_sensor_proved_ends_a_controlled_stop() -> None:
    rolling = replace(CONTROLLED, speed_mps=0.5)
    watch, _ = check_h1(StopWatch(), rolling, STOPPING, 1.0)
    assert watch.rolled
    watch, _ = check_h1(watch, CONTROLLED, STOPPING, 1.5)  # standing from here
    assert watch.standstill_since == 1.5
    assert check_h1(watch, CONTROLLED, STOPPING, 1.5 + STANDSTILL_GRACE_S)[1] is None
    assert check_h1(watch, CONTROLLED, STOPPING, 1.5 + STANDSTILL_GRACE_S + 0.001)[1]
    untrusted = replace(STOPPING, sensor_untrusted=True)  # its standstill proves nothing
    assert check_h1(watch, CONTROLLED, untrusted, 1.6)[1] is None


def test_rolling_slower_than_the_standstill_threshold_proves_no_standstill() -> None:
    creeping = replace(CONTROLLED, speed_mps=0.05 + 0.1)
    watch, _ = check_h1(StopWatch(), creeping, STOPPING, 1.0)
    assert not watch.rolled
    assert watch.standstill_since is None
    watch, _ = check_h1(watch, CONTROLLED, STOPPING, 1.5)
    assert check_h1(watch, CONTROLLED, STOPPING, 2.0)[1] is None
