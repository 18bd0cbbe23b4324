"""Event-driven input readers: IBUS bytes and CAN frames in, stamped and checked values out.

A reader is polled whenever the clock wakes the loop; it drains its port without blocking. Bad
frames are counted and dropped, never fatal. Each reader keeps a `RecentFault` per kind of bad
input so that the matching error flag is set while faults keep coming and clears on recovery,
and, in `link_faults`, its port's own failures (`LinkState`): the link down, failed re-opens,
failed receives. Those are reported, never acted on: a port that delivers nothing stops the
robot through the input's timeout, as a silent sender does.
"""

from __future__ import annotations

import operator
from collections import Counter
from collections.abc import Sequence
from dataclasses import replace

from bywire.can_frame import CanFrame
from bywire.config import TimeoutsSection
from bywire.control.command_edges import NO_EDGES, CommandEdges
from bywire.control.input_stage import (
    COUNTER_MISS_LIMIT,
    COUNTER_WINDOW,
    Decoded,
    EdgeState,
    MessageState,
    StopRequests,
    Verdict,
    edges_forgotten,
    edges_step,
    message_step,
    stop_request_step,
)
from bywire.control.rc_mapping import RcMapping, RcRequest, RcStage, rc_step
from bywire.control.validity import Stamped
from bywire.hal.ports import LINK_UP, ByteStream, CanPort, LinkState
from bywire.model import Command, ControlCommand, ControlMode
from bywire.protocol import dbc
from bywire.protocol.ibus import IbusParser
from bywire.runtime.recent_fault import RecentFault
from bywire.runtime.rx_checks import RxCheck, rx_check, rx_checks
from bywire.security.session import AuthFailure, SecocReceiver

__all__ = [
    "COUNTER_MISS_LIMIT",
    "COUNTER_WINDOW",
    "CanReader",
    "IbusReader",
    "LinkFaults",
    "arrival",
]


class LinkFaults:
    """A port's `LinkState`, read on every poll, as faults that keep a flag up while they last:
    `down` at every poll that finds the link down (counted once per loss); `reopen_failed` and
    `receive_failed` at every poll that finds their counts grown (by how much), and, while the
    link stays down, at every poll after: a failure that lost the link, or kept it lost, is up
    as long as the loss, so the report sent once the link is back still names it."""

    def __init__(self) -> None:
        self.down = RecentFault()
        self.reopen_failed = RecentFault()
        self.receive_failed = RecentFault()
        self.last = LINK_UP

    def read(self, link: LinkState, now: float) -> None:
        last = self.last
        if link is not last:  # a port with nothing wrong hands back the same value every time
            if link.reopen_failures > last.reopen_failures:
                self.reopen_failed.happened(now, link.reopen_failures - last.reopen_failures)
            if link.receive_failures > last.receive_failures:
                self.receive_failed.happened(now, link.receive_failures - last.receive_failures)
            self.last = link
        if link.down:
            self.down.happened(now, 0 if last.down else 1)
            for failed in (self.reopen_failed, self.receive_failed):
                if failed.active(now):
                    failed.happened(now, 0)


class IbusReader:
    """RC receiver bytes → the latest RC request; None as value for an implausible frame. The
    switches are decoded with their bands and hysteresis, and the gear debounced, by the pure
    RC stage (`bywire.control.rc_mapping.rc_step`)."""

    def __init__(self, stream: ByteStream, mapping: RcMapping, debounce_frames: int = 3) -> None:
        self._stream = stream
        self._mapping = mapping
        self._debounce_frames = debounce_frames
        self.stage = RcStage()
        self.parser = IbusParser()
        self.checksum_faults = RecentFault()
        self.resync_faults = RecentFault()
        self.link_faults = LinkFaults()
        self.last_channels: tuple[int, ...] | None = None
        self._mapped: tuple[tuple[int, ...], RcStage, RcStage, RcRequest | None] | None = None

    def poll(self, now: float) -> Stamped[RcRequest | None] | None:
        """The request of the frames completed since the last poll (`_batch_request`: the newest,
        at STOP if any of them was, its value None if any was implausible), or None if no frame
        completed."""
        self.link_faults.read(self._stream.link, now)
        data = self._stream.read_available()
        if not data:
            return None
        parser = self.parser
        checksum_errors, resyncs = parser.checksum_errors, parser.resyncs
        frames = parser.feed(data, _believed(self._stream.arrived_at_s, now))
        if parser.checksum_errors > checksum_errors:
            self.checksum_faults.happened(now, parser.checksum_errors - checksum_errors)
        if parser.resyncs > resyncs:
            self.resync_faults.happened(now, parser.resyncs - resyncs)
        if not frames:
            return None
        self.last_channels = frames[-1]
        requests = [self._request(channels) for channels in frames]
        arrived_at = parser.last_frame_at
        return Stamped(_batch_request(requests), now if arrived_at is None else arrived_at)

    def _request(self, channels: tuple[int, ...]) -> RcRequest | None:
        """`rc_step` of the frame, mapped once for a run of equal frames in an equal stage: held
        sticks and switches send the same channels about 140 times a second."""
        mapped = self._mapped
        # operator.ne for the stage: compiled, != between @value instances is identity (issue 43)
        if mapped is None or mapped[0] != channels or operator.ne(mapped[1], self.stage):
            stage, request = rc_step(self.stage, channels, self._mapping, self._debounce_frames)
            mapped = self._mapped = (channels, self.stage, stage, request)
        self.stage = mapped[2]
        return mapped[3]


def _batch_request(requests: Sequence[RcRequest | None]) -> RcRequest | None:
    """The newest request of the frames one poll read, judged by the worst of them: one
    implausible frame makes the input suspect at once (R-FAILSAFE), and one frame at STOP
    means STOP (a move to STOP acts on one frame, even when the loop was held up and read
    several at once); at the STOP position if any of them was, else between positions."""
    newest = requests[-1]
    if newest is None or None in requests:
        return None
    if len(requests) == 1:
        return newest
    stops = [r for r in requests if r is not None and r.mode is ControlMode.STOP]
    if not stops:
        return newest
    between = all(request.mode_between for request in stops)
    if newest.mode is ControlMode.STOP and newest.mode_between is between:
        return newest
    return replace(newest, mode=ControlMode.STOP, mode_between=between)


def arrival(frame: CanFrame, now: float) -> float:
    """When `frame` arrived: its port's timestamp (taken by the receive thread, or the simulated
    bus, on the loop's clock), so a frame that waited while the loop was busy is judged by its
    true age. A stamp from the future, or none, is not believed: `now` then."""
    return _believed(frame.timestamp_s, now)


def _believed(stamp: float | None, now: float) -> float:
    """A port's arrival stamp if it can be true (after 0, not after `now`), else `now`."""
    return stamp if stamp is not None and 0.0 < stamp <= now else now


class CanReader:
    """Controller's CAN port → checked commands: the shell of the CAN input stage.

    Every rule lives in the pure stage (`bywire.control.input_stage`): per command message, the
    counter, repeats, second senders (a counter the sequence passed, from the bus asking anything
    but what it carried with it) and trust;
    ControlCommand's edges and their settling after a gap; and the stop requests that pass every
    filter (R-STOP-PASS). This class only reads the port, decodes each frame with the codec,
    steps the stage with the frame's arrival stamp, and counts and flags what it refused.

    Trust is proportionate, by the command row (`bywire.command_table`): `untrusted_kinds` names
    the messages whose id is not trusted now; one whose row moves the robot (`untrusted`) stops
    CAN mode (CAN_UNTRUSTED), another (the lights) affects its own function alone.

    With `secoc` (authentication on), a command frame counts only once its cryptographic PDU
    has arrived and verified (`bywire.security.session`), the two paired by their arrival stamps;
    a failure rejects it whole, is counted in `auth_failures` and flags CAN_AUTH_FAILED, but costs
    the id no trust: a node without the key must not be able to make the computer's signed frames
    (its stop among them) be dropped. Verified frames then go through the stage as above.
    """

    def __init__(
        self,
        port: CanPort,
        checks: Sequence[RxCheck] | None = None,
        secoc: SecocReceiver | None = None,
    ) -> None:
        """`checks`: the receive check of each command message (default: every command of the
        DBC with the default timeouts); ids without a row are ignored."""
        checks = rx_checks(TimeoutsSection()) if checks is None else checks
        self._port = port
        self._secoc = secoc
        self.auth_failures: Counter[AuthFailure] = Counter()
        self.auth_faults = RecentFault()
        self._rows = {check.frame_id: check for check in checks}
        self._gap_s = rx_check(checks, ControlCommand).timeout_s
        self._control_id = dbc.frame_id(ControlCommand)
        self.states = {frame_id: MessageState() for frame_id in self._rows}
        """Each command message's input-stage state, by frame id."""
        self.rejected: Counter[dbc.RejectReason] = Counter()
        self.verdicts: Counter[Verdict] = Counter()
        self.reject_faults = RecentFault()
        self.link_faults = LinkFaults()
        self.ignored_frames = 0
        self.control_edges = NO_EDGES
        """The edges of the ControlCommand frames accepted by the latest poll (any of them)."""
        self._edges = EdgeState()
        self._stops = StopRequests()

    @property
    def stop_requests(self) -> int:
        """How many remote stop requests have arrived: the decision acts on a change."""
        return self._stops.count

    @property
    def untrusted(self) -> bool:
        """A command message that moves the robot is not trusted now (CAN_UNTRUSTED)."""
        return any(
            state.untrusted
            for frame_id, state in self.states.items()
            if self._rows[frame_id].moves_the_robot
        )

    @property
    def untrusted_kinds(self) -> frozenset[type[Command]]:
        """The command messages whose id is not trusted now."""
        if not any(state.untrusted for state in self.states.values()):
            return frozenset()
        return frozenset(
            self._rows[frame_id].kind for frame_id, state in self.states.items() if state.untrusted
        )

    @property
    def untrusted_frames(self) -> int:
        return self.verdicts[Verdict.UNTRUSTED]

    def poll(self, now: float) -> list[Stamped[Command]]:
        """Every command accepted since the last poll, oldest first."""
        accepted: list[Stamped[Command]] = []
        self.control_edges = NO_EDGES
        secoc = self._secoc
        self.link_faults.read(self._port.link, now)
        for frame in self._port.receive():
            frame_id, data = frame.arbitration_id, frame.data
            arrived_at = arrival(frame, now)
            if secoc is not None and frame_id in secoc.received_ids:
                outcome = secoc.offer(frame_id, data, arrived_at)
                if outcome.failures:
                    self._auth_failed(outcome.failures, now)
                if outcome.verified is None:
                    continue
                frame_id, data = outcome.verified
            command = self._staged(frame_id, data, arrived_at, now)
            if command is not None:
                accepted.append(Stamped(command, arrived_at))
        if secoc is not None and (expired := secoc.expire(now)):
            self._auth_failed(expired, now)
        return accepted

    def _staged(self, frame_id: int, data: bytes, arrived_at: float, now: float) -> Command | None:
        """One frame through the input stage: its command if it is to be used."""
        row = self._rows.get(frame_id)
        if row is None:
            self.ignored_frames += 1
            return None
        decoded, reason = _decoded(frame_id, data)
        if frame_id == self._control_id:
            self._stops = stop_request_step(self._stops, decoded.command, arrived_at, self._gap_s)
        state, verdict = message_step(self.states[frame_id], decoded, arrived_at, row.timeout_s)
        self.states[frame_id] = state
        self.verdicts[verdict] += 1
        if not verdict.used:
            self._refused(frame_id, verdict, reason, now)
            return None
        command = decoded.command
        if isinstance(command, ControlCommand):
            self._edges, edges = edges_step(self._edges, command, arrived_at, self._gap_s)
            self.control_edges = CommandEdges(
                re_enable=self.control_edges.re_enable or edges.re_enable,
                remote_stop=self.control_edges.remote_stop or edges.remote_stop,
            )
            if edges.remote_stop:  # a 0→1 between accepted frames: a new request, however soon
                self._stops = StopRequests(self._stops.count + 1, self._stops.seen_at)
        return command

    def _refused(
        self, frame_id: int, verdict: Verdict, reason: dbc.RejectReason | None, now: float
    ) -> None:
        """Count and flag a frame the stage refused (an identical repeat is neither)."""
        if verdict is Verdict.REPEAT:
            return
        if frame_id == self._control_id:
            self._edges = edges_forgotten(self._edges)
        if reason is not None:
            self.rejected[reason] += 1
        elif verdict is Verdict.COUNTER:
            self.rejected[dbc.RejectReason.COUNTER] += 1
        self.reject_faults.happened(now)

    def _auth_failed(self, failures: Sequence[tuple[int, AuthFailure]], now: float) -> None:
        """Counted and flagged; never a miss of the id's trust window (see the class)."""
        for frame_id, failure in failures:
            self.auth_failures[failure] += 1
            self.auth_faults.happened(now)
            if frame_id == self._control_id:
                self._edges = edges_forgotten(self._edges)


def _decoded(frame_id: int, data: bytes) -> tuple[Decoded, dbc.RejectReason | None]:
    """The frame as the codec reads it, and why it refused it (None: intact and in range)."""
    try:
        command = dbc.decode_intact(frame_id, data)
    except dbc.CommandRejected as rejected:
        if rejected.reason is dbc.RejectReason.RANGE:
            return Decoded(readable=True, counter=rejected.counter), rejected.reason
        return Decoded(readable=False), rejected.reason
    return Decoded(readable=True, counter=command.counter, command=command), None
