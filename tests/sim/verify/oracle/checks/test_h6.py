"""H6's check alone: throttle with a brake for longer than a control period."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h6 import check_h6
from bywire.sim.verify.oracle.invariants import Invariant
from tests.sim.verify.oracle.checks.shown import DRIVING

PERIOD_S = 0.010
BRAKED = replace(DRIVING, hydrobrake_duty=0.5)


def test_throttle_with_the_brake_is_flagged_after_a_control_period() -> None:
    since, found = check_h6(None, BRAKED, False, PERIOD_S, 1.0)
    assert (since, found) == (1.0, None)
    assert check_h6(since, BRAKED, False, PERIOD_S, 1.0 + PERIOD_S + 0.001) == (1.0, None)
    since, found = check_h6(since, BRAKED, False, PERIOD_S, 1.0 + PERIOD_S + 0.002)
    assert found is not None
    assert found.invariant is Invariant.H6
    assert since == 1.0


def test_regeneration_counts_as_a_brake() -> None:
    regen = replace(DRIVING, regen_volts=0.5)
    assert check_h6(1.0, regen, False, PERIOD_S, 1.1)[1] is not None


def test_no_brake_no_throttle_no_enable_or_an_unsure_dac_end_the_combination() -> None:
    assert check_h6(1.0, DRIVING, False, PERIOD_S, 1.1) == (None, None)
    assert check_h6(1.0, replace(BRAKED, throttle_volts=0.0), False, PERIOD_S, 1.1) == (None, None)
    assert check_h6(1.0, replace(BRAKED, enable=False), False, PERIOD_S, 1.1) == (None, None)
    assert check_h6(1.0, BRAKED, True, PERIOD_S, 1.1) == (None, None)
