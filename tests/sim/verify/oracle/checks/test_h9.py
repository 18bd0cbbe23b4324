"""H9's check alone: a source taking over moves the steering no faster than the requirement's
rate, which falls as 1/speed above 1 m/s."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.model import ControlMode
from bywire.sim.verify.oracle.cause_deadlines import ServoPulses
from bywire.sim.verify.oracle.checks.h9 import TakeOver, check_h9, handover_rate
from bywire.sim.verify.oracle.invariants import Invariant
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import REQUIRED_HANDOVER_RATE
from tests.sim.verify.oracle.checks.shown import DRIVING

SERVO = ServoPulses()  # 1.5 ms ± 0.5 ms
TAKING = TakeOver(ControlMode.CAN, from_s=1.0)


def _at(norm: float) -> Outputs:
    return replace(DRIVING, steering_pulse_s=SERVO.pulse_s(norm))


def test_the_rate_is_the_requirement_s_below_1_m_s_and_falls_as_1_over_speed() -> None:
    assert handover_rate(0.0) == handover_rate(-1.0) == REQUIRED_HANDOVER_RATE
    assert handover_rate(2.0) == pytest.approx(REQUIRED_HANDOVER_RATE / 2)


def test_nothing_is_judged_in_stop_or_before_the_switch_settled() -> None:
    sampled = replace(TAKING, last=(1.1, SERVO.pulse_s(0.0)))
    stopped = replace(DRIVING, released=False)
    assert check_h9(sampled, stopped, 0.9, SERVO, 1.2) == (TAKING, None)
    assert check_h9(sampled, DRIVING, 0.9, SERVO, 0.9) == (TAKING, None)


def test_the_take_over_ends_once_the_pulse_reached_the_source_s_steering() -> None:
    assert check_h9(TAKING, _at(0.89), 0.9, SERVO, 1.5) == (None, None)


def test_a_move_within_the_rate_passes_and_a_faster_one_is_flagged_with_its_bound() -> None:
    taking, found = check_h9(TAKING, _at(0.0), 0.9, SERVO, 1.5)
    assert found is None
    assert taking == replace(TAKING, last=(1.5, SERVO.pulse_s(0.0)))
    allowed = REQUIRED_HANDOVER_RATE * 0.1 + 0.02  # in 0.1 s at standstill
    assert taking is not None
    slow = check_h9(taking, _at(allowed - 0.01), 0.9, SERVO, 1.6)
    assert slow[1] is None
    taking, found = check_h9(taking, _at(0.5), 0.9, SERVO, 1.6)
    assert found is not None
    assert found.invariant is Invariant.H9
    assert found.expected == {
        "steering_pulse_max_s": pytest.approx(SERVO.pulse_s(0.0) + allowed * SERVO.half_span_s)
    }
