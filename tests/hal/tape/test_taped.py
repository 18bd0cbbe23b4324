"""Taped ports: outputs noted when they change, CAN frames every time, sensor reads that change,
DAC writes that hang, input ports' link states that change."""

from __future__ import annotations

from bywire.can_frame import CanFrame
from bywire.hal.ports import LINK_UP, LinkState
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.dac import SimDac6574
from bywire.hal.simulated.gpio_pwm import SimPwmChannel
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.uart import SimUart
from bywire.hal.tape.playback import ReplayByteStream, ReplayCanPort, ReplayDac, ReplayWheelSpeeds
from bywire.hal.tape.run_record import RecordedRun, RecordHeader, link_of
from bywire.hal.tape.taped import (
    Tape,
    TapedByteStream,
    TapedCanPort,
    TapedDac,
    TapedPwm,
    TapedSensor,
)
from bywire.protocol import dac6574


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


def test_a_dac_write_that_hangs_is_taped_with_when_it_returned_and_hangs_as_long_on_replay() -> (
    None
):
    clock = VirtualClock()
    dac = SimDac6574(clock)
    dac.on_stall = clock.advance  # as the simulated world wires it
    tape = Tape(clock)
    taped = TapedDac(dac, tape)
    frame = dac6574.encode_write(0, 512)
    taped.write(frame)
    dac.stall_next_write(0.3)
    taped.write(frame)
    stalls = [(e["t"], e["call"], e["s"]) for e in tape.events if e["kind"] == "stall"]
    assert stalls == [(0.3, 1, 0.3)]
    record = RecordedRun(RecordHeader("x", 0.0, 1.0, {}, (), ""))
    for event in tape.events:
        record.add(event)
    replay_clock = VirtualClock()
    ticks: list[float] = []
    PeriodicTimer(replay_clock, 0.1, ticks.append).start()  # the watchdog's timer, say
    replayed = ReplayDac(
        SimDac6574(replay_clock), set(), stalls=(replay_clock, record.stalls["dac"])
    )
    replayed.write(frame)
    assert (replay_clock.now(), ticks) == (0.0, [])
    replayed.write(frame)
    assert replay_clock.now() == 0.3
    assert len(ticks) == 3  # the timers ran inside the hung write, as they did when recorded


def test_a_ports_link_is_noted_when_it_changes_and_replayed_from_then() -> None:
    clock = VirtualClock()
    tape = Tape(clock)
    sim_can, uart = SimCanBus(clock).attach("bywire", True), SimUart(clock)
    can, rc = TapedCanPort(sim_can, tape), TapedByteStream(uart, tape)
    seen: list[tuple[float, LinkState, LinkState]] = []

    def read(time_s: float) -> None:
        clock.advance(time_s - clock.now())
        seen.append((time_s, can.link, rc.link))

    read(0.1)
    sim_can.enter_bus_off()
    read(0.2)
    read(0.3)
    uart.fail()
    sim_can.recover_bus_off()
    read(0.4)
    uart.restore()
    read(0.5)
    noted = [(e["t"], e["name"], link_of(e)) for e in tape.events if e["kind"] == "link"]
    assert noted == [
        (0.2, "can", LinkState(down=True)),
        (0.4, "can", LINK_UP),
        (0.4, "rc_uart", LinkState(down=True)),
        (0.5, "rc_uart", LINK_UP),
    ]
    replayed_clock = VirtualClock()
    links = {name: [(t, link) for t, n, link in noted if n == name] for name in ("can", "rc_uart")}
    replayed_can = ReplayCanPort(replayed_clock, [], set(), links["can"])
    replayed_rc = ReplayByteStream(replayed_clock, [], links["rc_uart"])
    replayed = []
    for time_s, _, _ in seen:
        replayed_clock.advance(time_s - replayed_clock.now())
        replayed.append((time_s, replayed_can.link, replayed_rc.link))
    assert replayed == seen
