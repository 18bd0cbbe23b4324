"""Event-driven input readers: IBUS bytes and CAN frames in, stamped and checked values out.

A reader is polled whenever the clock wakes the loop; it drains its port without blocking. Bad
frames are counted and dropped, never fatal. Each reader keeps a `RecentFault` per kind of bad
input so that the matching error flag is set while faults keep coming and clears on recovery.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Sequence
from dataclasses import replace

from bywire.config import TimeoutsSection
from bywire.control.command_edges import NO_EDGES, CommandEdges, command_edges
from bywire.control.rc_mapping import RcMapping, RcRequest, rc_request
from bywire.control.validity import Stamped
from bywire.hal.ports import ByteStream, CanFrame, CanPort
from bywire.model import Command, ControlCommand, ControlMode, LightsCommand
from bywire.protocol import dbc
from bywire.protocol.ibus import IbusParser
from bywire.runtime.recent_fault import RecentFault
from bywire.runtime.rx_checks import RxCheck, rx_check, rx_checks
from bywire.security.session import AuthFailure, SecocReceiver

COUNTER_WINDOW = 16  # the last frames of a command message whose counters are judged
COUNTER_MISS_LIMIT = 3  # this many counter misses among them: the message is not trusted


class IbusReader:
    """RC receiver bytes → the latest RC request; None as value for an implausible frame."""

    def __init__(self, stream: ByteStream, mapping: RcMapping) -> None:
        self._stream = stream
        self._mapping = mapping
        self.parser = IbusParser()
        self.checksum_faults = RecentFault()
        self.resync_faults = RecentFault()
        self.last_channels: tuple[int, ...] | None = None
        self._mapped: tuple[tuple[int, ...], RcRequest | None] | None = None

    def poll(self, now: float) -> Stamped[RcRequest | None] | None:
        """The request of the frames completed since the last poll (`_batch_request`: the newest,
        at STOP if any of them was, its value None if any was implausible), or None if no frame
        completed."""
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
        """`rc_request` of the frame, mapped once for a run of equal frames: held sticks and
        switches send the same channels about 140 times a second."""
        if self._mapped is None or self._mapped[0] != channels:
            self._mapped = (channels, rc_request(channels, self._mapping))
        return self._mapped[1]


def _batch_request(requests: Sequence[RcRequest | None]) -> RcRequest | None:
    """The newest request of the frames one poll read, judged by the worst of them: one
    implausible frame makes the input suspect at once (R-FAILSAFE), and one frame at STOP
    means STOP (a move to STOP acts on one frame, even when the loop was held up and read
    several at once)."""
    newest = requests[-1]
    if newest is None or None in requests:
        return None
    if newest.mode is not ControlMode.STOP and any(
        request is not None and request.mode is ControlMode.STOP for request in requests
    ):
        return replace(newest, mode=ControlMode.STOP)
    return newest


def arrival(frame: CanFrame, now: float) -> float:
    """When `frame` arrived: its port's timestamp (taken by the receive thread, or the simulated
    bus, on the loop's clock), so a frame that waited while the loop was busy is judged by its
    true age. A stamp from the future, or none, is not believed: `now` then."""
    return _believed(frame.timestamp_s, now)


def _believed(stamp: float | None, now: float) -> float:
    """A port's arrival stamp if it can be true (after 0, not after `now`), else `now`."""
    return stamp if stamp is not None and 0.0 < stamp <= now else now


class _CounterTrust:
    """Whether one command message's counter can be trusted, judged over its last frames."""

    def __init__(self) -> None:
        self.misses: deque[bool] = deque(maxlen=COUNTER_WINDOW)
        self.untrusted = False

    def record(self, miss: bool) -> None:
        self.misses.append(miss)
        count = sum(self.misses)
        if count >= COUNTER_MISS_LIMIT:
            self.untrusted = True
        elif count == 0 and len(self.misses) == COUNTER_WINDOW:
            self.untrusted = False


class CanReader:
    """Controller's CAN port → checked commands; counters judged per message, rejects counted.

    Each command message's counter is judged over its last COUNTER_WINDOW frames (opendbc judges
    a leaky count; a window also catches what that misses): COUNTER_MISS_LIMIT repeated or
    skipped counters among them make the message *untrusted*. A second sender on the id, or a
    replaying node, then cannot drive even with half its frames intact (a leaky count of +1 per
    miss and -1 per good frame stays balanced at half). Its frames are dropped until a whole
    window of good frames in a row. Trust is proportionate: an untrusted movement or control id
    (`untrusted`) stops CAN mode (CAN_UNTRUSTED); an untrusted lights id (`lights_untrusted`)
    affects the lights alone (the last trusted request is held, LIGHTS_UNTRUSTED).

    A stop always gets through: a ControlCommand frame that is intact (length, CRC, ranges) and
    asks for a remote stop counts as a stop request whatever its counter or the id's trust, with
    authentication on once it verified (`stop_requests`, see `_stop_passes`). Only leaving STOP
    needs trust: a re-enable is taken from accepted frames alone.

    ControlCommand edges (`control_edges`, see `bywire.control.command_edges`) are taken between
    consecutive accepted frames: a rejected or dropped frame, or a gap longer than `gap_s`,
    leaves no previous frame to compare with; and after a gap a re-enable counts only once the
    frames have been arriving for `gap_s` again (a burst of queued frames is no request).

    With `secoc` (authentication on), a command frame counts only once its cryptographic PDU
    has arrived and verified (`bywire.security.session`); a failure rejects it whole, is
    counted in `auth_failures` and flags CAN_AUTH_FAILED, but costs the id no trust: a node
    without the key must not be able to make the computer's signed frames (its stop among them)
    be dropped. The counter of verified frames is judged as without authentication.
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
        self._gap_s = rx_check(checks, ControlCommand).timeout_s
        self._command_ids = frozenset(check.frame_id for check in checks)
        self._control_id = dbc.frame_id(ControlCommand)
        self._lights_id = dbc.frame_id(LightsCommand)
        self.stop_requests = 0
        """How many remote stop requests have arrived (`_stop_passes`): the decision acts on a
        change, in every mode."""
        self._stop_seen_at: float | None = None  # the newest intact frame asking for a stop
        self._previous_counter: dict[int, int | None] = dict.fromkeys(self._command_ids)
        self.trust = {frame_id: _CounterTrust() for frame_id in self._command_ids}
        self.rejected: Counter[dbc.RejectReason] = Counter()
        self.reject_faults = RecentFault()
        self.ignored_frames = 0
        self.untrusted_frames = 0
        self.control_edges = NO_EDGES
        """The edges of the ControlCommand frames accepted by the latest poll (any of them)."""
        self._previous_control: Stamped[ControlCommand] | None = None
        self._control_back_at = 0.0  # when ControlCommand frames resumed after a gap

    @property
    def untrusted(self) -> bool:
        """A movement or control command message is not trusted now (CAN_UNTRUSTED)."""
        return any(
            trust.untrusted for frame_id, trust in self.trust.items() if frame_id != self._lights_id
        )

    @property
    def lights_untrusted(self) -> bool:
        """The lights command is not trusted now: it affects the lights alone."""
        trust = self.trust.get(self._lights_id)
        return trust is not None and trust.untrusted

    def poll(self, now: float) -> list[Stamped[Command]]:
        """Every command accepted since the last poll, oldest first."""
        accepted: list[Stamped[Command]] = []
        self.control_edges = NO_EDGES
        secoc = self._secoc
        if secoc is not None and (expired := secoc.expire(now)):
            self._auth_failed(expired, now)
        for frame in self._port.receive():
            frame_id, data = frame.arbitration_id, frame.data
            if secoc is not None and frame_id in secoc.received_ids:
                outcome = secoc.offer(frame_id, data, now)
                if outcome.failures:
                    self._auth_failed(outcome.failures, now)
                if outcome.verified is None:
                    continue
                frame_id, data = outcome.verified
            if frame_id not in self._command_ids:
                self.ignored_frames += 1
                continue
            if frame_id == self._control_id:
                self._stop_passes(data, arrival(frame, now))
            command = self._checked(frame_id, data, now)
            if command is None:
                if frame_id == self._control_id:
                    self._previous_control = None
                continue
            arrived_at = arrival(frame, now)
            if isinstance(command, ControlCommand):
                self._edges(command, arrived_at)
            accepted.append(Stamped(command, arrived_at))
        return accepted

    def _checked(self, frame_id: int, data: bytes, now: float) -> Command | None:
        """The decoded command, or None when rejected or untrusted (counted either way)."""
        try:
            command = dbc.decode_command(frame_id, data, self._previous_counter[frame_id])
        except dbc.CommandRejected as rejected:
            self._reject(rejected, now)
            return None
        self._previous_counter[frame_id] = command.counter
        trust = self.trust[frame_id]
        trust.record(miss=False)
        if trust.untrusted:
            self.untrusted_frames += 1
            self.reject_faults.happened(now)
            return None
        return command

    def _stop_passes(self, data: bytes, arrived_at: float) -> None:
        """A remote stop in an intact (or, with authentication, verified) ControlCommand frame
        arrives whatever its counter or the id's trust (R-STOP-PASS): the filters exist so that
        bad input cannot *move* the robot, and a stop only makes it safer. It arrives (a new
        request) when no intact frame asked for one within the command timeout before it; a
        request held by every frame is one arrival, so the RC operator may still take over."""
        try:
            command = dbc.decode_intact(self._control_id, data)
        except dbc.CommandRejected:
            return
        if not isinstance(command, ControlCommand) or not command.remote_stop:
            return
        seen_at = self._stop_seen_at
        if seen_at is None or arrived_at - seen_at > self._gap_s:
            self.stop_requests += 1
        self._stop_seen_at = arrived_at

    def _auth_failed(self, failures: Sequence[tuple[int, AuthFailure]], now: float) -> None:
        """Counted and flagged; never a miss of the id's trust window (see the class)."""
        for frame_id, failure in failures:
            self.auth_failures[failure] += 1
            self.auth_faults.happened(now)
            if frame_id == self._control_id:
                self._previous_control = None

    def _edges(self, command: ControlCommand, now: float) -> None:
        previous = self._previous_control
        recent = previous is not None and now - previous.received_at <= self._gap_s
        if not recent:
            self._control_back_at = now
        edges = command_edges(previous.value if previous is not None and recent else None, command)
        # Frames that waited in a transmit queue while the link was down arrive in a burst when
        # it is back: a request among them is stale. A re-enable counts once the link has been
        # back for one command timeout.
        settled = now - self._control_back_at >= self._gap_s
        self.control_edges = CommandEdges(
            re_enable=self.control_edges.re_enable or (edges.re_enable and settled),
            remote_stop=self.control_edges.remote_stop or edges.remote_stop,
        )
        if edges.remote_stop:  # a 0→1 between accepted frames: a new request, however soon
            self.stop_requests += 1
        self._previous_control = Stamped(command, now)

    def _reject(self, rejected: dbc.CommandRejected, now: float) -> None:
        self.rejected[rejected.reason] += 1
        self.reject_faults.happened(now)
        if rejected.reason is dbc.RejectReason.COUNTER:
            self.trust[rejected.frame_id].record(miss=True)
        # An intact frame: follow its counter, as panda does, so one lost frame does not reject
        # every later one. A frame the codec could not read says nothing of the sender's
        # sequence: the next frame starts it afresh instead of counting as a miss.
        self._previous_counter[rejected.frame_id] = rejected.counter
