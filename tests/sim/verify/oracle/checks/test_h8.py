"""H8's check alone: at the controller's end every output but the dead one is safe."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.checks.h8 import check_h8
from bywire.sim.verify.oracle.invariants import Invariant
from tests.sim.verify.oracle.checks.shown import DRIVING, STOPPED


def test_safe_outputs_pass_and_unsafe_ones_are_named() -> None:
    assert check_h8(STOPPED, set(), False, 1.0) is None
    found = check_h8(DRIVING, set(), False, 1.0)
    assert found is not None
    assert found.invariant is Invariant.H8
    assert found.detail == (
        "after the controller ended: not safe: motors_enable, ebrake_release, hydrobrake, dac"
    )


def test_a_dead_line_and_a_failing_dac_are_not_held_against_the_exit() -> None:
    braking_dead = replace(STOPPED, hydrobrake_duty=0.0, throttle_volts=1.0)
    assert check_h8(braking_dead, {"hydrobrake"}, True, 1.0) is None
    found = check_h8(braking_dead, {"hydrobrake"}, False, 1.0)
    assert found is not None
    assert found.detail.endswith("not safe: dac")
