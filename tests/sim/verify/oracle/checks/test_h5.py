"""H5's check alone: in STOP the hydraulic brake is at full duty and the steering holds."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h5 import check_h5
from bywire.sim.verify.oracle.checks.hold import SteeringHold
from bywire.sim.verify.oracle.invariants import Invariant
from tests.sim.verify.oracle.checks.shown import STOPPED


def test_nothing_is_judged_while_the_drive_need_not_be_cut_and_the_hold_ends() -> None:
    held = SteeringHold(0.0017, 1.0)
    assert check_h5(held, replace(STOPPED, hydrobrake_duty=0.0), False, False, 2.0) == (
        SteeringHold(),
        (),
    )


def test_a_stop_without_full_hydraulic_duty_is_flagged() -> None:
    _, found = check_h5(SteeringHold(), replace(STOPPED, hydrobrake_duty=0.5), True, False, 2.0)
    assert [(v.invariant, v.detail, v.expected) for v in found] == [
        (Invariant.H5, "in STOP: hydraulic brake at 0.50 duty", {"hydrobrake_duty_min": 1.0})
    ]


def test_the_steering_holds_from_the_first_pass_in_stop() -> None:
    hold, found = check_h5(SteeringHold(), STOPPED, True, False, 2.0)
    assert found == ()
    turned = replace(STOPPED, steering_pulse_s=0.0016, hydrobrake_duty=0.5)
    _, found = check_h5(hold, turned, True, False, 2.1)
    assert [v.detail for v in found] == [
        "in STOP: hydraulic brake at 0.50 duty",
        "in STOP: steering pulse 1.600 ms, held at 1.500 ms",
    ]
    assert found[1].expected["steering_held_since_s"] == 2.0
    _, boosted = check_h5(hold, turned, True, True, 2.1)  # a boosted pulse settles: brake only
    assert [v.detail for v in boosted] == ["in STOP: hydraulic brake at 0.50 duty"]
