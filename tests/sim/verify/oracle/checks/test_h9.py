"""H9's check alone: a source taking over moves the steering no faster than the requirement's
rate, which falls as 1/speed above 1 m/s."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.control.steering import SteeringConfig
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


CALIBRATION = SteeringConfig(
    min_pulse_s=0.001375, center_pulse_s=0.0015, max_pulse_s=0.002, reverse=True
)
"""`bywire verify --draw-robots 10 --seed 2`, file 4: a legal calibration 0.125 ms to the left
of centre and 0.5 ms to the right, reversed."""
LOPSIDED = ServoPulses.of(CALIBRATION)


def _pulse(norm: float) -> Outputs:
    """What the servo is sent for `norm`, from the calibration's numbers: reversed, then each
    side of centre on its own span."""
    side = -norm
    span_s = 0.0005 if side >= 0.0 else 0.000125
    return replace(DRIVING, steering_pulse_s=0.0015 + side * span_s)


@pytest.mark.parametrize("toward", [-0.9, 0.9])
def test_a_lopsided_servo_s_handover_is_judged_in_steering_norms_on_either_side(
    toward: float,
) -> None:
    """Each side on its own span: at the rate on the long side passes (judged on the shorter
    span, as before, it moved 4 times too fast), a faster move is flagged, its bound the pulse
    of the allowed norm."""
    taking, _ = check_h9(TAKING, _pulse(0.0), toward, LOPSIDED, 1.5)
    assert taking is not None
    allowed = REQUIRED_HANDOVER_RATE * 0.1 + 0.02  # in 0.1 s at standstill
    direction = 1.0 if toward > 0 else -1.0
    assert check_h9(taking, _pulse(direction * (allowed - 0.01)), toward, LOPSIDED, 1.6)[1] is None
    found = check_h9(taking, _pulse(direction * 0.5), toward, LOPSIDED, 1.6)[1]
    assert found is not None
    edge_s = _pulse(direction * allowed).steering_pulse_s
    assert list(found.expected.values()) == [pytest.approx(edge_s)]


def test_a_lopsided_servo_s_pulses_and_norms_are_each_other_s_inverse() -> None:
    for norm in (-1.0, -0.5, 0.0, 0.3, 1.0):
        assert LOPSIDED.pulse_s(norm) == pytest.approx(_pulse(norm).steering_pulse_s)
        assert LOPSIDED.norm_of(LOPSIDED.pulse_s(norm)) == pytest.approx(norm)
