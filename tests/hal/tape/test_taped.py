"""Taped ports: outputs noted when they change, CAN frames every time, sensor reads that change."""

from __future__ import annotations

from bywire.hal.ports import CanFrame
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.gpio_pwm import SimPwmChannel
from bywire.hal.tape.playback import ReplayCanPort, ReplayWheelSpeeds
from bywire.hal.tape.taped import Tape, TapedCanPort, TapedPwm, TapedSensor


def test_taped_outputs_are_noted_on_change_and_can_frames_every_time() -> None:
    clock = VirtualClock()
    tape = Tape(clock)
    pwm = TapedPwm(SimPwmChannel(clock, 0.02), "steering_pwm", tape)
    for pulse_s in (0.0015, 0.0015, 0.0016):
        pwm.set_pulse(pulse_s)
    port = TapedCanPort(ReplayCanPort(clock, [], refused_calls={1}), tape)
    assert [port.send(CanFrame(0x200, b"\x01")) for _ in range(2)] == [True, False]
    kinds = [(e["kind"], e.get("name"), e.get("value", e.get("call"))) for e in tape.events]
    assert kinds == [
        ("out", "steering_pwm", 0.0015),
        ("out", "steering_pwm", 0.0016),
        ("out", "can_tx.0x200", "01"),
        ("out", "can_tx.0x200", "01"),
        ("refused", "can_tx", 1),
    ]


def test_a_taped_sensor_notes_the_reads_that_change_and_replays_them_in_order() -> None:
    tape = Tape(VirtualClock())
    values = iter([(0.0, 0.0), (0.0, 0.0), (1.0, 1.0), None])
    sensor = TapedSensor(lambda: next(values), "wheel_speeds", tape)
    readings = [sensor.read() for _ in range(4)]
    changes = [(e["read"], e["value"]) for e in tape.events]
    assert changes == [(0, (0.0, 0.0)), (2, (1.0, 1.0)), (3, None)]
    replayed = ReplayWheelSpeeds(changes)
    assert [replayed.read() for _ in range(4)] == readings
