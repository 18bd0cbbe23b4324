"""The suite every backend passes, simulated and Linux alike: the seam's promises, port by port.

Write → read back through the backend's stand-in, inputs fed on the far side arrive, filters
hold, bad requests fail the same way, closing de-energises every output, and closing twice is
harmless. Linux-only: a missing device is one clear HardwareError, and what was already opened
is closed again. The tape backend runs it too: taped simulated ports (and the tape must hold what
crossed) and the playback ports `bywire replay` runs on; a test that cannot apply to a rig is left
out by that rig's `NOT_APPLICABLE`, which says why.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bywire.can_frame import CanFrame
from bywire.errors import FrameError, HardwareError
from bywire.hal.hardware import OUTPUT_NAMES
from bywire.hal.ports import LinkState
from bywire.protocol import dac6574, dbc, ibus
from tests.hal.rigs import (
    BACKENDS,
    Rig,
    TapedSimRig,
    make_rig,
    not_applicable,
    settle_until,
)

LINES = list(OUTPUT_NAMES)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Every test on every backend, but those a rig names as not applicable (with its reason)."""
    if "rig" in metafunc.fixturenames:
        test = metafunc.function.__name__
        backends = [backend for backend in BACKENDS if test not in not_applicable(backend)]
        metafunc.parametrize("rig", backends, indirect=True)


@pytest.fixture
def rig(
    request: pytest.FixtureRequest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[Rig]:
    opened = make_rig(request.param, tmp_path, monkeypatch)
    yield opened
    opened.close()


def test_every_test_a_rig_leaves_out_exists_and_has_a_reason() -> None:
    tests = {name for name in globals() if name.startswith("test_")}
    left_out = {
        (backend, test): why
        for backend in BACKENDS
        for test, why in not_applicable(backend).items()
    }
    assert {test for _, test in left_out} <= tests
    assert all(len(why.split()) >= 5 for why in left_out.values())
    assert ("playback", "test_command_frames_arrive_and_other_ids_are_filtered") in left_out


@pytest.mark.parametrize("name", LINES)
def test_a_line_reads_back_what_was_written(rig: Rig, name: str) -> None:
    line = rig.hardware.outputs.line(name)
    line.set(True)
    assert rig.level(name) is True
    assert not any(rig.level(other) for other in LINES if other != name)
    line.set(False)
    assert rig.level(name) is False


@pytest.mark.parametrize(
    ("name", "period_s", "pulse_s"), [("steering", 0.020, 0.0017), ("hydrobrake", 0.001, 0.0004)]
)
def test_a_pwm_pulse_reads_back(rig: Rig, name: str, period_s: float, pulse_s: float) -> None:
    pwm = getattr(rig.hardware, f"{name}_pwm")
    assert pwm.period_s == pytest.approx(period_s)
    pwm.set_pulse(pulse_s)
    assert rig.pulse_s(name) == pytest.approx(pulse_s)
    pwm.set_pulse(0.0)
    assert rig.pulse_s(name) == 0.0


@pytest.mark.parametrize("pulse_s", [-1e-6, 0.0201, float("nan")])
def test_a_pulse_outside_the_period_is_refused(rig: Rig, pulse_s: float) -> None:
    with pytest.raises(HardwareError, match="outside"):
        rig.hardware.steering_pwm.set_pulse(pulse_s)


@pytest.mark.parametrize(("channel", "code"), [(0, 1023), (1, 1), (3, 512)])
def test_a_dac_frame_sets_its_channel(rig: Rig, channel: int, code: int) -> None:
    rig.hardware.dac.write(dac6574.encode_write(channel, code))
    assert rig.dac_code(channel) == code


@pytest.mark.parametrize("frame", [b"", b"\x10\x00", b"\xff\xff\xff"])
def test_a_malformed_dac_frame_is_a_hardware_error(rig: Rig, frame: bytes) -> None:
    with pytest.raises(HardwareError):
        rig.hardware.dac.write(frame)


def test_rc_bytes_arrive_whole_and_in_order(rig: Rig) -> None:
    channels = tuple(1000 + 37 * index for index in range(ibus.CHANNEL_COUNT))
    sent = ibus.encode_frame(channels) * 3
    received = bytearray()
    rig.feed_rc(sent)
    assert settle_until(rig, lambda: _collect(rig, received) >= len(sent))
    assert bytes(received) == sent


def test_rc_bytes_carry_when_they_arrived_not_when_they_were_read(rig: Rig) -> None:
    clock = rig.hardware.clock
    fed_at_s = clock.now()
    rig.feed_rc(ibus.encode_frame([1500] * ibus.CHANNEL_COUNT))
    received = bytearray()
    assert settle_until(rig, lambda: _collect(rig, received) >= ibus.FRAME_LENGTH)
    arrived_at_s = rig.hardware.rc_uart.arrived_at_s
    assert arrived_at_s is not None
    assert fed_at_s <= arrived_at_s <= clock.now()


def _collect(rig: Rig, into: bytearray) -> int:
    into.extend(rig.hardware.rc_uart.read_available())
    return len(into)


def test_rc_input_cuts_a_wait_short(rig: Rig) -> None:
    clock = rig.hardware.clock
    deadline_s = clock.now() + 60.0
    rig.feed_rc(ibus.encode_frame([1500] * ibus.CHANNEL_COUNT))
    clock.wait_until(deadline_s)
    assert clock.now() < deadline_s


def _down_then_back(
    rig: Rig, link: Callable[[], LinkState], lose: Callable[[], None], back: Callable[[], None]
) -> None:
    """The port's link is up, says it is down once lost, and up again once back."""
    assert not link().down
    lose()
    assert settle_until(rig, lambda: link().down)
    back()
    assert settle_until(rig, lambda: not link().down)


def test_a_lost_rc_line_says_so_and_bytes_arrive_once_it_is_back(rig: Rig) -> None:
    uart = rig.hardware.rc_uart
    _down_then_back(rig, lambda: uart.link, rig.lose_rc_line, rig.restore_rc_line)
    sent = ibus.encode_frame([1500] * ibus.CHANNEL_COUNT)
    rig.feed_rc(sent)
    received = bytearray()
    assert settle_until(rig, lambda: _collect(rig, received) >= len(sent))
    assert bytes(received) == sent


def test_a_can_port_off_the_bus_says_so_and_frames_arrive_once_it_is_back(rig: Rig) -> None:
    port = rig.hardware.can
    _down_then_back(rig, lambda: port.link, rig.take_can_off_bus, rig.put_can_back)
    movement_id = dbc.command_ids()[1]
    rig.peer_send(movement_id, bytes(range(8)))
    frames: list[CanFrame] = []

    def received() -> bool:
        frames.extend(port.receive())
        return bool(frames)

    assert settle_until(rig, received)
    assert [(frame.arbitration_id, frame.data) for frame in frames] == [
        (movement_id, bytes(range(8)))
    ]


def test_command_frames_arrive_and_other_ids_are_filtered(rig: Rig) -> None:
    movement_id = dbc.command_ids()[1]
    rig.peer_send(0x7FF, b"\x01")
    rig.peer_send(movement_id, bytes(range(8)))
    frames: list[CanFrame] = []

    def received() -> bool:
        frames.extend(rig.hardware.can.receive())
        return bool(frames)

    assert settle_until(rig, received)
    rig.settle()
    frames.extend(rig.hardware.can.receive())
    assert [(frame.arbitration_id, frame.data) for frame in frames] == [
        (movement_id, bytes(range(8)))
    ]


def test_a_sent_report_reaches_the_other_node(rig: Rig) -> None:
    assert rig.hardware.can.send(CanFrame(0x200, b"\x12\x34"))
    received: list[tuple[int, bytes]] = []

    def arrived() -> bool:
        received.extend(rig.peer_frames())
        return bool(received)

    assert settle_until(rig, arrived)
    assert received == [(0x200, b"\x12\x34")]


@pytest.mark.parametrize(("frame_id", "data"), [(0x800, b""), (-1, b""), (0x100, bytes(9))])
def test_a_frame_classic_can_cannot_carry_is_refused(rig: Rig, frame_id: int, data: bytes) -> None:
    with pytest.raises(FrameError):
        rig.hardware.can.send(CanFrame(frame_id, data))


def _drive_everything(rig: Rig) -> None:
    for name in LINES:
        rig.hardware.outputs.line(name).set(True)
    rig.hardware.steering_pwm.set_pulse(0.0015)
    rig.hardware.hydrobrake_pwm.set_pulse(0.0005)
    for channel in (0, 1):
        rig.hardware.dac.write(dac6574.encode_write(channel, 800))


def _assert_de_energised(rig: Rig) -> None:
    assert {name: rig.level(name) for name in LINES} == dict.fromkeys(LINES, False)
    assert (rig.pulse_s("steering"), rig.pulse_s("hydrobrake")) == (0.0, 0.0)
    assert (rig.dac_code(0), rig.dac_code(1)) == (0, 0)


def test_closing_de_energises_every_output(rig: Rig) -> None:
    _drive_everything(rig)
    rig.close()
    _assert_de_energised(rig)


def test_closing_twice_is_harmless(rig: Rig) -> None:
    _drive_everything(rig)
    rig.close()
    rig.close()
    _assert_de_energised(rig)


def test_the_taped_rig_fails_a_tape_that_lost_what_crossed() -> None:
    rig = TapedSimRig()
    rig.hardware.outputs.low_beam.set(True)
    assert rig.level("low_beam") is True
    rig.tape.events.pop()  # the tape loses the line's change
    with pytest.raises(AssertionError, match="low_beam"):
        rig.level("low_beam")
    rig.tape.events.clear()
    rig.world.gpio["low_beam"].history.clear()
    rig.feed_rc(b"\x20\x40")
    assert settle_until(rig, lambda: bool(rig.hardware.rc_uart.read_available()))
    rig.tape.events.clear()  # the tape loses the bytes read
    with pytest.raises(AssertionError, match="RC bytes"):
        rig.check_tape()
    rig.witness.rc.clear()
    rig.take_can_off_bus()
    assert rig.hardware.can.link.down
    rig.check_tape()
    rig.tape.events.clear()  # the tape loses the link's change
    with pytest.raises(AssertionError, match="can links"):
        rig.check_tape()
