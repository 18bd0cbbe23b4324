"""Playback ports: recorded inputs arrive at their instants, recorded refusals are refused again."""

from __future__ import annotations

import pytest

from bywire.can_frame import CanFrame
from bywire.errors import HardwareError
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.tape.playback import ReplayByteStream, ReplayCanPort, ReplayDac


def test_replayed_inputs_arrive_at_their_recorded_instants() -> None:
    clock = VirtualClock()
    stream = ReplayByteStream(
        clock, [(0.1, b"\x20", 0.09), (0.1, b"\x40", 0.095), (0.2, b"\x01", None)]
    )
    port = ReplayCanPort(clock, [(0.15, [CanFrame(0x101, b"", 0.15)])], set())
    assert stream.read_available() == b""
    clock.advance(0.1)
    assert (stream.read_available(), port.receive()) == (b"\x20\x40", [])
    assert stream.arrived_at_s == 0.095  # the newest byte's recorded stamp
    clock.advance(0.1)
    assert stream.read_available() == b"\x01"
    assert stream.arrived_at_s is None  # a record made before stamps were kept
    assert port.receive() == [CanFrame(0x101, b"", 0.15)]


def test_the_replayed_dac_refuses_exactly_the_recorded_writes() -> None:
    written: list[bytes] = []

    class Device:
        def write(self, data: bytes) -> None:
            written.append(data)

    dac = ReplayDac(Device(), refused_calls={1})
    dac.write(b"a")
    with pytest.raises(HardwareError, match="as recorded"):
        dac.write(b"b")
    dac.write(b"c")
    assert written == [b"a", b"c"]
