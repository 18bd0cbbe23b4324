"""Event-driven input readers: IBUS bytes and CAN frames in, stamped and checked values out.

A reader is polled whenever the clock wakes the loop; it drains its port without blocking. Bad
frames are counted and dropped, never fatal. Each reader keeps a `RecentFault` per kind of bad
input so that the matching error flag is set while faults keep coming and clears on recovery.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from bywire.control.rc_mapping import RcMapping, RcRequest, rc_request
from bywire.control.validity import Stamped
from bywire.hal.ports import ByteStream, CanPort
from bywire.model import Command
from bywire.protocol import dbc
from bywire.protocol.ibus import IbusParser

FAULT_HOLD_S = 0.5  # a flag stays up this long after the last bad frame, so a report catches it
COUNTER_FAIL_LIMIT = 3  # a message with this many unbalanced counter errors is not trusted
COUNTER_FAIL_MAX = 10  # the leaky counter saturates here, so recovery never takes forever


@dataclass(slots=True)
class RecentFault:
    """When a kind of fault last happened, and how often."""

    count: int = 0
    last_at: float | None = None

    def happened(self, now: float, times: int = 1) -> None:
        self.count += times
        self.last_at = now

    def active(self, now: float) -> bool:
        return self.last_at is not None and now - self.last_at <= FAULT_HOLD_S


class IbusReader:
    """RC receiver bytes → the latest RC request; None as value for an implausible frame."""

    def __init__(self, stream: ByteStream, mapping: RcMapping) -> None:
        self._stream = stream
        self._mapping = mapping
        self.parser = IbusParser()
        self.checksum_faults = RecentFault()
        self.resync_faults = RecentFault()
        self.last_channels: tuple[int, ...] | None = None

    def poll(self, now: float) -> Stamped[RcRequest | None] | None:
        """The request carried by the newest complete frame, or None if no frame completed."""
        data = self._stream.read_available()
        if not data:
            return None
        before = self.parser.stats
        frames = self.parser.feed(data, now)
        after = self.parser.stats
        if after.checksum_errors > before.checksum_errors:
            self.checksum_faults.happened(now, after.checksum_errors - before.checksum_errors)
        if after.resyncs > before.resyncs:
            self.resync_faults.happened(now, after.resyncs - before.resyncs)
        if not frames:
            return None
        self.last_channels = frames[-1]
        requests = [rc_request(channels, self._mapping) for channels in frames]
        # One implausible frame in the batch makes the input suspect at once (R-FAILSAFE).
        return Stamped(None if None in requests else requests[-1], now)


class CanReader:
    """Controller's CAN port → checked commands; counters tracked per message, rejects counted.

    Each command message has a leaky counter of counter errors (as opendbc's CANParser does): a
    repeated or skipped counter adds one, a good frame takes one away. While it stands at
    COUNTER_FAIL_LIMIT or more, even intact frames of that message are not used: a sender whose
    counter keeps jumping (two senders on one id, a replaying node) is not trusted until it has
    sent that many good frames in a row.
    """

    def __init__(self, port: CanPort) -> None:
        self._port = port
        self._command_ids = frozenset(dbc.command_ids())
        self._previous_counter: dict[int, int | None] = dict.fromkeys(self._command_ids)
        self.counter_fail: dict[int, int] = dict.fromkeys(self._command_ids, 0)
        self.rejected: Counter[dbc.RejectReason] = Counter()
        self.reject_faults = RecentFault()
        self.ignored_frames = 0
        self.untrusted_frames = 0

    def poll(self, now: float) -> list[Stamped[Command]]:
        """Every command accepted since the last poll, oldest first."""
        accepted: list[Stamped[Command]] = []
        for frame in self._port.receive():
            frame_id = frame.arbitration_id
            if frame_id not in self._command_ids:
                self.ignored_frames += 1
                continue
            try:
                command = dbc.decode_command(frame_id, frame.data, self._previous_counter[frame_id])
            except dbc.CommandRejected as rejected:
                self._reject(rejected, now)
                continue
            self._previous_counter[frame_id] = command.counter
            self.counter_fail[frame_id] = max(self.counter_fail[frame_id] - 1, 0)
            if self.counter_fail[frame_id] >= COUNTER_FAIL_LIMIT:
                self.untrusted_frames += 1
                self.reject_faults.happened(now)
                continue
            accepted.append(Stamped(command, now))
        return accepted

    def _reject(self, rejected: dbc.CommandRejected, now: float) -> None:
        self.rejected[rejected.reason] += 1
        self.reject_faults.happened(now)
        if rejected.reason is dbc.RejectReason.COUNTER:
            fails = self.counter_fail[rejected.frame_id] + 1
            self.counter_fail[rejected.frame_id] = min(fails, COUNTER_FAIL_MAX)
        if rejected.counter is not None:
            # The frame was intact: follow its counter, as panda does, so one lost frame does
            # not reject every later one.
            self._previous_counter[rejected.frame_id] = rejected.counter
