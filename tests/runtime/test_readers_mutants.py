"""Readers' bookkeeping, exactly: every bad frame counted once and stamped with the poll time,
the hold of a fault flag inclusive, a suspect RC frame anywhere in a batch, and frames after an
unknown id still read."""

from __future__ import annotations

from bywire.control.rc_mapping import RcMapping
from bywire.hal.ports import CanFrame
from bywire.hal.sim.can_bus import SimCanBus
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.uart import SimUart
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc, ibus
from bywire.runtime.readers import FAULT_HOLD_S, CanReader, IbusReader, RecentFault

CHANNELS = (1750, 1500, 1500, 1500, 1500, 1000, 1500) + (1500,) * 7
FRAME = ibus.encode_frame(CHANNELS)
CORRUPT = FRAME[:-1] + bytes([FRAME[-1] ^ 0xFF])
FAILSAFE = ibus.encode_frame((1500, 900) + (1500,) * 12)
MOVEMENT_ID = dbc.frame_id(MovementCommand)


# --- RecentFault -------------------------------------------------------------------------------


def test_a_fault_counts_once_by_default() -> None:
    fault = RecentFault()
    fault.happened(1.0)
    assert fault.count == 1


def test_a_fault_flag_is_held_for_exactly_the_hold_time_inclusive() -> None:
    fault = RecentFault()
    fault.happened(1.0)
    assert FAULT_HOLD_S == 0.5
    assert fault.active(1.5)
    assert not fault.active(1.5001)


# --- IBUS --------------------------------------------------------------------------------------


class Receiver:
    """An RC receiver's UART and the controller's reader on it."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        self.uart = SimUart(self.clock)
        self.reader = IbusReader(self.uart, RcMapping())

    def poll_after(self, data: bytes) -> float:
        """Send `data`, let it arrive, poll; the poll time."""
        self.uart.transmit(data)
        self.clock.advance(0.05)
        now = self.clock.now()
        self.reader.poll(now)
        return now


def test_checksum_faults_are_counted_per_bad_frame_and_stamped_with_the_poll_time() -> None:
    rx = Receiver()
    rx.poll_after(CORRUPT + CORRUPT + FRAME)
    second_s = rx.poll_after(CORRUPT + FRAME)
    assert rx.reader.checksum_faults.count == 3
    assert rx.reader.checksum_faults.last_at == second_s


def test_resyncs_are_counted_per_realignment_and_stamped_with_the_poll_time() -> None:
    rx = Receiver()
    rx.poll_after(b"\x01\x02\x03" + FRAME + b"\x06" + FRAME)
    second_s = rx.poll_after(b"\x04\x05" + FRAME)
    assert rx.reader.resync_faults.count == 3
    assert rx.reader.resync_faults.last_at == second_s


def test_the_reader_keeps_the_newest_raw_channels_and_stamps_its_parser() -> None:
    rx = Receiver()
    assert rx.reader.last_channels is None
    now = rx.poll_after(FRAME)
    assert rx.reader.last_channels == CHANNELS
    assert rx.reader.parser.last_frame_at == now


def test_one_failsafe_frame_anywhere_in_a_batch_makes_the_batch_suspect() -> None:
    rx = Receiver()
    rx.uart.transmit(FAILSAFE + FRAME)
    rx.clock.advance(0.05)
    stamped = rx.reader.poll(rx.clock.now())
    assert stamped is not None
    assert stamped.value is None


# --- CAN ---------------------------------------------------------------------------------------


class Link:
    """A sender and the controller's reader on one simulated bus."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        bus = SimCanBus(self.clock)
        self.sender = bus.attach("hlc", tx_mailboxes=64)
        self.reader = CanReader(bus.attach("bywire", True))

    def queue(self, *counters: int) -> None:
        for counter in counters:
            frame_id, payload = dbc.encode_command(
                MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, counter)
            )
            self.sender.send(CanFrame(frame_id, payload))

    def poll(self) -> tuple[float, list[int]]:
        self.clock.advance(0.05)
        now = self.clock.now()
        return now, [stamped.value.counter for stamped in self.reader.poll(now)]


def test_a_new_reader_trusts_every_command_message() -> None:
    link = Link()
    assert set(link.reader.counter_fail.values()) == {0}


def test_a_frame_with_an_unknown_id_is_skipped_and_the_rest_of_the_batch_still_read() -> None:
    link = Link()
    link.sender.send(CanFrame(0x7FF, b"\x00" * 8))
    link.sender.send(CanFrame(0x7FE, b"\x00" * 8))
    link.queue(1)
    _, accepted = link.poll()
    assert accepted == [1]
    assert link.reader.ignored_frames == 2


def test_corrupt_frames_are_counted_per_frame_and_flagged_at_the_poll_time() -> None:
    link = Link()
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 0))
    bad = bytes([payload[0] ^ 1, *payload[1:]])
    link.sender.send(CanFrame(MOVEMENT_ID, bad))
    link.sender.send(CanFrame(MOVEMENT_ID, bad))
    now, accepted = link.poll()
    assert accepted == []
    assert link.reader.rejected[dbc.RejectReason.CHECKSUM] == 2
    assert link.reader.reject_faults.count == 2
    assert link.reader.reject_faults.last_at == now


def test_every_untrusted_frame_is_counted_and_flagged_at_the_poll_time() -> None:
    link = Link()
    link.queue(0, 2, 4, 6, 8, 10)  # five skipped counters: the leaky counter stands at 5
    link.poll()
    link.queue(11, 12, 13)  # 5 -> 4 and 4 -> 3 still untrusted; 3 -> 2 used
    now, accepted = link.poll()
    assert accepted == [13]
    assert link.reader.untrusted_frames == 2
    assert link.reader.reject_faults.last_at == now
