"""The steering hold of H3 and H5: the first reading begins it, any other pulse leaves it."""

from __future__ import annotations

from bywire.sim.verify.oracle.checks.hold import SteeringHold


def test_the_first_reading_begins_the_hold_and_another_pulse_leaves_it() -> None:
    hold, moved = SteeringHold().step(0.0017, 1.0)
    assert (hold, moved) == (SteeringHold(0.0017, 1.0), False)
    assert hold.step(0.0017, 2.0) == (hold, False)  # held since 1.0, not since 2.0
    assert hold.step(0.0016, 2.0) == (hold, True)
