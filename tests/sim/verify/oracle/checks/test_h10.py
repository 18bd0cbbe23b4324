"""H10's check alone: a failed hydraulic brake or a stuck servo engages the e-brake within the
requirement's deadline (0.5 s at duty 0.2 or more; 2.0 s at 0.3 off), whatever the file says."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.sim.verify.oracle.checks.h10 import BrokenFacts, Unnoticed, check_h10
from bywire.sim.verify.oracle.invariants import Invariant
from bywire.sim.verify.oracle.outputs import Outputs
from tests.sim.verify.oracle.checks.shown import DRIVING, STOPPED

PERIOD_S = 0.010
SLACK_S = 2 * PERIOD_S + 0.005
BROKEN_BRAKE = BrokenFacts(True, True, False, 0.0, PERIOD_S)
STUCK_SERVO = BrokenFacts(True, False, True, 0.0, PERIOD_S)
BRAKING = replace(DRIVING, throttle_volts=0.0, hydrobrake_duty=0.4)
OFF = replace(DRIVING, steering_norm=0.0, asked_steering_norm=0.5)  # stuck straight, 0.5 asked


def judged(facts: BrokenFacts, out: Outputs, times: list[float]) -> list[float]:
    """When H10 flags, over passes at `times` showing `out`."""
    memory, flagged = Unnoticed(), []
    for now in times:
        memory, found = check_h10(memory, out, facts, now)
        if found is not None:
            assert found.invariant is Invariant.H10
            assert found.expected["ebrake_engaged"] is True
            flagged.append(now)
    return flagged


@pytest.mark.parametrize(
    ("facts", "out", "deadline_s"), [(BROKEN_BRAKE, BRAKING, 0.5), (STUCK_SERVO, OFF, 2.0)]
)
def test_a_broken_actuator_unacted_on_past_the_deadline_is_flagged_once(
    facts: BrokenFacts, out: Outputs, deadline_s: float
) -> None:
    limit = 1.0 + deadline_s + SLACK_S
    assert judged(facts, out, [1.0, limit - 0.001]) == []  # within the deadline: allowed
    assert judged(facts, out, [1.0, limit + 0.001]) == [limit + 0.001]
    # judged afresh after a finding, not at every pass
    assert judged(facts, out, [1.0, limit + 0.001, limit + 0.002]) == [limit + 0.001]


@pytest.mark.parametrize(
    ("facts", "out"),
    [
        (BROKEN_BRAKE, STOPPED),  # the e-brake engaged: acted on
        (BROKEN_BRAKE, replace(BRAKING, hydrobrake_duty=0.2)),  # a duty at the figure's edge
        (BROKEN_BRAKE, replace(BRAKING, hydrobrake_duty=0.1)),  # too light to expect pressure
        (replace(BROKEN_BRAKE, hydrobrake_failed=False), BRAKING),  # the brake works
        (replace(BROKEN_BRAKE, sensors_fitted=False), BRAKING),  # nothing to notice it with
        (STUCK_SERVO, replace(OFF, asked_steering_norm=0.3)),  # 0.3 off: within the figure
        (replace(STUCK_SERVO, servo_stuck=False), OFF),  # a servo still turning
        (replace(STUCK_SERVO, boost_gain=1.0), OFF),  # 0.5 of boosted pulse: 0.25 of set-point
        (replace(STUCK_SERVO, sensors_fitted=False), OFF),
    ],
)
def test_no_fault_past_the_figures_is_no_finding(facts: BrokenFacts, out: Outputs) -> None:
    assert judged(facts, out, [1.0, 4.0]) == []


def test_a_condition_that_lapses_starts_afresh() -> None:
    memory, found = check_h10(Unnoticed(), BRAKING, BROKEN_BRAKE, 1.0)
    memory, found = check_h10(memory, replace(BRAKING, hydrobrake_duty=0.0), BROKEN_BRAKE, 1.3)
    assert memory == Unnoticed()
    memory, found = check_h10(memory, BRAKING, BROKEN_BRAKE, 1.4)
    memory, found = check_h10(memory, BRAKING, BROKEN_BRAKE, 1.8)
    assert found is None  # 0.4 s since it began again, not 0.8 s
    assert memory.pressure_since == 1.4


def test_a_servo_chasing_a_command_that_keeps_moving_is_timed_from_where_it_holds() -> None:
    # The deadline is derived for a command the servo does not follow; a pulse that moves on
    # starts the time afresh (the slowest acceptable servo would be chasing it too).
    memory, _ = check_h10(Unnoticed(), OFF, STUCK_SERVO, 1.0)
    memory, _ = check_h10(memory, replace(OFF, asked_steering_norm=0.505), STUCK_SERVO, 2.0)
    assert memory.servo_since == 1.0  # within 0.01: held
    memory, _ = check_h10(memory, replace(OFF, asked_steering_norm=-0.6), STUCK_SERVO, 2.5)
    assert memory.servo_since == 2.5  # moved on
    later = 2.5 + 2.0 + SLACK_S
    moved = replace(OFF, asked_steering_norm=-0.6)
    assert check_h10(memory, moved, STUCK_SERVO, later - 0.001)[1] is None
    assert check_h10(memory, moved, STUCK_SERVO, later + 0.001)[1] is not None
