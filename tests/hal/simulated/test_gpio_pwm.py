"""Simulated GPIO and PWM: current value, change-only history with times, sysfs-like limits."""

from __future__ import annotations

import pytest

from bywire.errors import HardwareError
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.gpio_pwm import SimDigitalOut, SimPwmChannel


def test_digital_out_records_first_set_and_changes_only() -> None:
    clock = VirtualClock()
    line = SimDigitalOut(clock, "motors_enable")
    assert line.level is False
    assert line.history == []
    for time_s, level in [(0.0, False), (0.1, False), (0.2, True), (0.3, True), (0.4, False)]:
        clock.advance(time_s - clock.now())
        line.set(level)
    assert line.history == [(0.0, False), (0.2, True), (0.4, False)]
    assert line.level is False
    assert line.writes == 5
    assert line.last_write_s == pytest.approx(0.4)


def test_digital_out_level_at_reads_the_waveform() -> None:
    clock = VirtualClock()
    line = SimDigitalOut(clock)
    clock.advance(1.0)
    line.set(True)
    clock.advance(1.0)
    line.set(False)
    assert [line.level_at(t) for t in (0.5, 1.0, 1.5, 2.0, 9.0)] == [
        False,
        True,
        True,
        False,
        False,
    ]


def test_pwm_records_pulse_history_and_duty() -> None:
    clock = VirtualClock()
    servo = SimPwmChannel(clock, 0.02, "steering")
    assert servo.period_s == 0.02
    assert servo.pulse_s == 0.0
    servo.set_pulse(0.0015)
    servo.set_pulse(0.0015)
    clock.advance(0.01)
    servo.set_pulse(0.002)
    assert servo.history == [(0.0, 0.0015), (0.01, 0.002)]
    assert servo.duty == pytest.approx(0.1)
    assert servo.pulse_at(0.005) == 0.0015
    assert servo.writes == 3


@pytest.mark.parametrize("pulse_s", [-1e-6, 0.0011, float("nan")])
def test_pwm_refuses_a_pulse_outside_its_period(pulse_s: float) -> None:
    brake = SimPwmChannel(VirtualClock(), 0.001)
    with pytest.raises(HardwareError, match="outside"):
        brake.set_pulse(pulse_s)
    assert brake.history == []


def test_pwm_period_must_be_positive() -> None:
    with pytest.raises(ValueError, match="period"):
        SimPwmChannel(VirtualClock(), 0.0)


def test_history_limit_keeps_at_least_the_latest_entries() -> None:
    clock = VirtualClock()
    line = SimDigitalOut(clock, history_limit=10)
    for index in range(1000):
        clock.advance(0.001)
        line.set(index % 2 == 0)
    assert 10 <= len(line.history) < 20
    time_s, level = line.history[-1]
    assert time_s == pytest.approx(1.0)
    assert level is False
    assert line.level_at(0.9995) is True
