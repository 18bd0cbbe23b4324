"""H11's check alone: with a speed limit and a trusted wheel sensor, the true speed never passes
the limit by more than a fifth of it (at least 0.2 m/s), in either direction; flagged once per
excursion."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.sim.verify.oracle.checks.h11 import LimitFacts, check_h11
from bywire.sim.verify.oracle.invariants import Invariant
from bywire.sim.verify.oracle.outputs import Outputs
from tests.sim.verify.oracle.checks.shown import DRIVING, STOPPED

LIMITED = LimitFacts(2.0, sensor_trusted=True)


def judged(facts: LimitFacts, speeds: list[float], out: Outputs = DRIVING) -> list[int]:
    """The passes (by index) at which H11 flags, over passes showing each speed."""
    over, flagged = False, []
    for index, speed in enumerate(speeds):
        over, found = check_h11(over, replace(out, speed_mps=speed), facts, float(index))
        if found is not None:
            assert found.invariant is Invariant.H11
            assert found.expected["speed_max_mps"] == pytest.approx(2.4)
            flagged.append(index)
    return flagged


def test_within_the_margin_is_allowed_past_it_is_flagged() -> None:
    assert judged(LIMITED, [1.0, 2.0, 2.3, 2.4]) == []
    assert judged(LIMITED, [2.0, 2.41]) == [1]
    assert judged(LIMITED, [-2.41]) == [0]  # reverse too
    assert judged(LIMITED, [2.5], STOPPED) == [0]  # whatever the outputs: the true speed


def test_one_finding_per_excursion() -> None:
    assert judged(LIMITED, [2.5, 2.6, 2.7]) == [0]
    assert judged(LIMITED, [2.5, 2.6, 2.3, 2.5]) == [0, 3]


@pytest.mark.parametrize(("limit", "bound"), [(0.1, 0.3), (1.0, 1.2), (10.0, 12.0)])
def test_the_margin_is_a_fifth_of_the_limit_at_least_two_tenths(limit: float, bound: float) -> None:
    facts = LimitFacts(limit, sensor_trusted=True)
    over, found = check_h11(False, replace(DRIVING, speed_mps=bound - 1e-9), facts, 0.0)
    assert (over, found) == (False, None)
    over, found = check_h11(False, replace(DRIVING, speed_mps=bound + 1e-6), facts, 0.0)
    assert over
    assert found is not None


def test_without_a_limit_or_a_trusted_sensor_nothing_is_judged() -> None:
    assert judged(LimitFacts(None, sensor_trusted=True), [9.0]) == []
    assert judged(LimitFacts(2.0, sensor_trusted=False), [9.0]) == []


def test_not_judged_once_both_mechanical_brakes_failed() -> None:
    assert judged(LimitFacts(2.0, sensor_trusted=True, brakes_failed=True), [9.0]) == []
