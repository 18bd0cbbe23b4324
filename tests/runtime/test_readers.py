"""Input readers on simulated ports: checked commands, counters followed, a leaky counter."""

from __future__ import annotations

import pytest

from bywire.control.rc_mapping import RcMapping
from bywire.hal.ports import CanFrame
from bywire.hal.sim.can_bus import SimCanBus
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.uart import SimUart
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc, ibus
from bywire.runtime.readers import COUNTER_FAIL_LIMIT, CanReader, IbusReader


class Link:
    """A sender and the controller's reader on one simulated bus."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        bus = SimCanBus(self.clock)
        self.sender = bus.attach("hlc", tx_mailboxes=64)
        self.reader = CanReader(bus.attach("bywire", True))

    def send(self, *counters: int, data: bytes | None = None) -> list[int]:
        """Send movement commands with these counters; the counters of the accepted ones."""
        for counter in counters:
            command = MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, counter)
            frame_id, payload = dbc.encode_command(command)
            self.sender.send(CanFrame(frame_id, data if data is not None else payload))
        self.clock.advance(0.05)
        return [stamped.value.counter for stamped in self.reader.poll(self.clock.now())]


def test_consecutive_counters_are_accepted_and_wrap() -> None:
    assert Link().send(14, 15, 0, 1) == [14, 15, 0, 1]


def test_a_repeated_frame_is_rejected_and_the_sequence_goes_on() -> None:
    link = Link()
    assert link.send(3, 4, 4, 5) == [3, 4, 5]
    assert link.reader.rejected[dbc.RejectReason.COUNTER] == 1


def test_one_lost_frame_costs_one_frame() -> None:
    link = Link()
    assert link.send(3, 5, 6) == [3, 6]  # 5 skipped a counter; 6 follows 5 and is accepted
    assert link.reader.counter_fail[dbc.frame_id(MovementCommand)] == 0


def test_a_jumping_counter_makes_the_message_untrusted_until_enough_good_frames() -> None:
    link = Link()
    jumps = [0, 2, 4, 6, 8]  # every frame skips one
    assert link.send(*jumps) == [0]
    assert link.reader.counter_fail[dbc.frame_id(MovementCommand)] == 4
    good = [9, 10, 11, 12]
    accepted = link.send(*good)
    # each good frame takes one away first; untrusted while the count is still >= the limit:
    # 4 -> 3 (untrusted), 3 -> 2 (used), 2 -> 1, 1 -> 0
    assert accepted == good[4 - COUNTER_FAIL_LIMIT :]
    assert link.reader.untrusted_frames == 4 - COUNTER_FAIL_LIMIT


def test_corrupt_frames_are_counted_and_never_returned() -> None:
    link = Link()
    frame_id, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 0))
    bad = bytes([payload[0] ^ 1, *payload[1:]])
    assert link.send(0, data=bad) == []
    assert link.reader.rejected[dbc.RejectReason.CHECKSUM] == 1
    assert frame_id in dbc.command_ids()


def test_unknown_ids_are_ignored() -> None:
    link = Link()
    link.sender.send(CanFrame(0x7FF, b"\x00" * 8))
    link.clock.advance(0.01)
    assert link.reader.poll(link.clock.now()) == []
    assert link.reader.ignored_frames == 1


@pytest.mark.parametrize("chunk", [1, 5, 32, 64])
def test_ibus_reader_returns_the_newest_request_stamped_now(chunk: int) -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    reader = IbusReader(uart, RcMapping())
    frame = ibus.encode_frame((1750, 1500, 1500, 1500, 1500, 1000, 1500) + (1500,) * 7)
    for start in range(0, len(frame), chunk):
        uart.transmit(frame[start : start + chunk])
    clock.advance(0.01)
    stamped = reader.poll(clock.now())
    assert stamped is not None
    assert stamped.received_at == clock.now()
    assert stamped.value is not None
    assert stamped.value.steering_norm == pytest.approx(0.5)


def test_ibus_reader_marks_a_failsafe_frame_as_suspect() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    reader = IbusReader(uart, RcMapping())
    uart.transmit(ibus.encode_frame((1500, 900) + (1500,) * 12))
    clock.advance(0.01)
    stamped = reader.poll(clock.now())
    assert stamped is not None
    assert stamped.value is None
