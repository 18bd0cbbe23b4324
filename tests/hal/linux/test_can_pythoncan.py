"""python-can backend on the virtual interface, a second bus playing the higher-level computer:
filtered reception, reports out, refusals instead of exceptions, bus-off and unplug recovered."""

from __future__ import annotations

import uuid
from collections.abc import Callable, Iterator
from typing import Any

import can
import pytest

from bywire.can_frame import CanFrame
from bywire.errors import ConfigError, HardwareError
from bywire.hal.linux.can_open import BusSettings, open_bus
from bywire.hal.linux.can_pythoncan import CAN_ERR_BUSOFF, BusHealth, PythonCanPort
from bywire.hal.linux.clock import LinuxClock
from bywire.protocol import dbc
from tests.hal.linux.unpluggable import Unpluggable

ATTEMPTS = 2000


@pytest.fixture
def channel() -> str:
    return f"bywire-can-{uuid.uuid4().hex[:8]}"


@pytest.fixture
def hlc(channel: str) -> Iterator[can.BusABC]:
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


def _port(
    channel: str, clock: LinuxClock, accept_ids: tuple[int, ...] = dbc.command_ids(), **kwargs: Any
) -> PythonCanPort:
    settings = BusSettings("virtual", channel, accept_ids=accept_ids)
    return PythonCanPort(settings, clock.notify_input, clock.now, **kwargs)


def _wait(clock: LinuxClock, condition: Callable[[], bool]) -> bool:
    for _ in range(ATTEMPTS):
        if condition():
            return True
        clock.wait_until(clock.now() + 0.01)
    return False


def test_commands_arrive_stamped_and_other_ids_are_filtered(channel: str, hlc: can.BusABC) -> None:
    clock = LinuxClock()
    port = _port(channel, clock)
    try:
        before_s = clock.now()
        hlc.send(can.Message(arbitration_id=0x7FF, data=b"\x01", is_extended_id=False))
        hlc.send(can.Message(arbitration_id=0x101, data=b"\x01", is_extended_id=True))
        hlc.send(can.Message(arbitration_id=0x100, data=b"\x02\x03\x04", is_extended_id=False))
        frames: list[CanFrame] = []

        def received() -> bool:
            frames.extend(port.receive())
            return bool(frames)

        assert _wait(clock, received)
    finally:
        port.close()
    assert [(frame.arbitration_id, frame.data) for frame in frames] == [(0x100, b"\x02\x03\x04")]
    assert frames[0].timestamp_s >= before_s


def test_reports_reach_the_higher_level_computer(channel: str, hlc: can.BusABC) -> None:
    port = _port(channel, LinuxClock())
    try:
        assert port.send(CanFrame(0x201, bytes(8)))
        message = hlc.recv(5.0)
    finally:
        port.close()
    assert message is not None
    assert (message.arbitration_id, message.is_extended_id) == (0x201, False)
    assert port.frames_sent == 1


def test_an_unplugged_adapter_refuses_sends_and_is_reopened(channel: str, hlc: can.BusABC) -> None:
    clock, adapter = LinuxClock(), Unpluggable()
    port = _port(channel, clock, bus_factory=adapter)
    try:
        adapter.plugged = False
        assert _wait(clock, lambda: port.health is BusHealth.DOWN)
        assert not port.send(CanFrame(0x200, b"\x00"))
        assert port.send_refused == 1
        assert "receive failed" in str(port.fault)
        assert _wait(clock, lambda: port.link.reopen_failures >= 2)
        assert port.link.down
        assert port.link.receive_failures == 1
        adapter.plugged = True
        assert _wait(clock, lambda: port.health is BusHealth.ACTIVE)
        assert not port.link.down
        assert port.send(CanFrame(0x200, b"\x00"))
        hlc.send(can.Message(arbitration_id=0x101, data=bytes(8), is_extended_id=False))
        assert _wait(clock, lambda: bool(port.receive()))
    finally:
        port.close()
    assert (adapter.opened, port.reopens, port.fault) == (2, 1, None)


def test_bus_off_is_flagged_and_cleared_when_frames_flow(channel: str, hlc: can.BusABC) -> None:
    clock = LinuxClock()
    # SocketCAN delivers error frames past the id filters; the virtual bus filters them away.
    port = _port(channel, clock, accept_ids=())
    try:
        hlc.send(
            can.Message(arbitration_id=CAN_ERR_BUSOFF, is_error_frame=True, is_extended_id=False)
        )
        assert _wait(clock, lambda: port.health is BusHealth.BUS_OFF)
        assert "bus-off" in str(port.fault)
        assert port.link.down
        hlc.send(can.Message(arbitration_id=0x101, data=bytes(8), is_extended_id=False))
        assert _wait(clock, lambda: port.health is BusHealth.ACTIVE)
    finally:
        port.close()
    assert port.bus_off_count == 1


def test_a_send_the_controller_refuses_returns_false(channel: str) -> None:
    class FullQueue(can.BusABC):
        def __init__(self) -> None:
            super().__init__(channel=channel)

        def send(self, msg: can.Message, timeout: float | None = None) -> None:
            raise can.CanOperationError("Transmit buffer full", 105)

        def _recv_internal(self, timeout: float | None) -> tuple[None, bool]:
            return None, False

    port = _port(channel, LinuxClock(), bus_factory=lambda settings: FullQueue())
    try:
        assert [port.send(CanFrame(0x200, b"")) for _ in range(3)] == [False] * 3
    finally:
        port.close()
    assert (port.send_refused, port.health) == (3, BusHealth.ACTIVE)


def test_close_twice_is_harmless(channel: str) -> None:
    port = _port(channel, LinuxClock())
    port.close()
    port.close()
    assert not port.send(CanFrame(0x200, b""))


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        (BusSettings("kvaser", "0"), "CAN kvaser 0: interface not available here: install Kvaser"),
        (BusSettings("nonsense", "0"), "CAN nonsense 0: unknown python-can interface 'nonsense'"),
        (
            BusSettings("slcan", "/nonexistent/ttyACM0"),
            "CAN slcan /nonexistent/ttyACM0: cannot open",
        ),
    ],
)
def test_an_interface_that_cannot_open_says_what_to_do(settings: BusSettings, message: str) -> None:
    with pytest.raises(HardwareError, match="^" + message.replace("(", r"\(")) as raised:
        open_bus(settings)
    assert "\n" not in str(raised.value)


def test_the_bitrate_is_checked_against_the_bit_timing_calculator() -> None:
    with pytest.raises(ConfigError, match="no exact bit timing"):
        open_bus(BusSettings("virtual", "x", bitrate_bps=300_000, clock_hz=16_000_000))
    open_bus(BusSettings("virtual", "x", bitrate_bps=500_000, clock_hz=48_000_000)).shutdown()
