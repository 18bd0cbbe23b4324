"""Freshness across restarts, attack by attack (docs/SECURITY.md, "What the trip counter
resists"): the controller, the sender, and both, each crashed (no clean close) and restarted
from their files; every frame ever recorded is then replayed, and none is accepted; frames the
sender made while the controller was down (pre-play) are not accepted after its start either;
the live sender is accepted again without any manual step.

Real code paths: the CAN reader of the runtime with its SecOC receiver, the controller's trip
counter file, the sender's signer hearing the trip counter on the simulated bus, on virtual
time; the files in a temporary directory.
"""

from __future__ import annotations

import datetime
import random
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_bus import LoggedFrame, SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.runtime.readers import COUNTER_WINDOW, CanReader
from bywire.security.freshness import FreshnessStore
from bywire.security.session import TRIP_IDS, AuthFailure, SecocReceiver, SecocSigner
from bywire.security.trip import reset_trip, start_trip

BLOCK = 8
PERIOD_S = 0.02
KEY = SecocKey(bytes(range(16)))
NOW = datetime.datetime(2026, 11, 26, 12, 0, tzinfo=datetime.UTC)


@dataclass
class Link:
    """A sender and the controller's CAN reader on one simulated bus, with an attacker's port.
    Every period the controller announces its trip counter (as its reports do), then the
    sender sends a movement command with its cryptographic PDU."""

    tmp_path: Path
    clock: VirtualClock = field(default_factory=VirtualClock)
    recorded: list[LoggedFrame] = field(default_factory=list)
    counter: int = 0
    rng: random.Random = field(default_factory=lambda: random.Random(33))
    trips: list[int] = field(default_factory=list)
    signer: SecocSigner = field(init=False)  # set by start_sender, again at each restart
    receiver: SecocReceiver | None = None  # set by start_controller; None while it is down

    def __post_init__(self) -> None:
        MADE.append(self)
        self.bus = SimCanBus(self.clock)
        self.sender_port = self.bus.attach("hlc", accept_ids=TRIP_IDS, tx_mailboxes=8)
        self.sender_port.set_listener(self._hear)
        self.attacker = self.bus.attach("attacker", accept_ids=(), tx_mailboxes=100_000)
        self.controller_port = self.bus.attach("bywire", True, accept_ids=dbc.received_ids())
        self.bus.add_monitor(self._record)
        reset_trip(self.controller_file, KEY, 0, NOW)  # the robot's first start: a new key
        self.start_sender()
        self.start_controller()

    @property
    def controller_file(self) -> Path:
        return self.tmp_path / "controller.json"

    def _hear(self, frame: CanFrame) -> None:
        self.signer.hear(frame.arbitration_id, frame.data)

    def _record(self, frame: LoggedFrame) -> None:
        if frame.sender == "hlc":
            self.recorded.append(frame)

    def start_sender(self) -> None:
        if hasattr(self, "signer"):
            self.signer.store.halt()  # a crash: nothing pending is written
        store = FreshnessStore(KEY, self.tmp_path / "sender.json", BLOCK)
        self.signer = SecocSigner(KEY, store)  # the old one is dropped: a crash, nothing flushed

    def stop_controller(self) -> None:
        self.receiver = None  # a crash: the process is gone, its port reads nothing

    def start_controller(self) -> None:
        trip = start_trip(self.controller_file, KEY, self.rng)
        self.trips.append(trip)
        self.receiver = SecocReceiver(KEY, trip, dbc.command_ids())
        self.reader = CanReader(self.controller_port, secoc=self.receiver)
        self.controller_port.receive()  # a restarted process opens a fresh socket

    def send(self, frames: int) -> list[MovementCommand]:
        """The next `frames` periods: the controller's announcement (while it runs), the
        sender's movement command (once it can sign); what the controller accepted."""
        accepted: list[MovementCommand] = []
        for _ in range(frames):
            if self.receiver is not None:
                for frame_id, data in self.receiver.announcement:
                    self.controller_port.send(CanFrame(frame_id, data))
                self.clock.advance(0.001)  # the announcement crosses the bus
            command = MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, self.counter)
            frame_id, payload = dbc.encode_command(command)
            authenticator = self.signer.authenticator(frame_id, payload)
            if authenticator is not None:
                self.counter = (self.counter + 1) % dbc.COUNTER_MODULUS
                self.sender_port.send(CanFrame(frame_id, payload))
                self.sender_port.send(authenticator)
            accepted += self._poll_after(PERIOD_S - 0.001)
        return accepted

    def replay(self, frames: list[LoggedFrame]) -> list[MovementCommand]:
        """`frames` again, from the attacker's port, paced as they were sent (each command
        frame with its cryptographic PDU)."""
        accepted: list[MovementCommand] = []
        for authentic, crypto in zip(frames[::2], frames[1::2], strict=True):
            self.attacker.send(CanFrame(authentic.arbitration_id, authentic.data))
            self.attacker.send(CanFrame(crypto.arbitration_id, crypto.data))
            accepted += self._poll_after(PERIOD_S)
        return accepted

    def replay_everything(self) -> list[MovementCommand]:
        """Every frame the sender ever put on the bus."""
        return self.replay(list(self.recorded))

    def _poll_after(self, duration_s: float) -> list[MovementCommand]:
        end_s = self.clock.now() + duration_s
        accepted: list[MovementCommand] = []
        while self.clock.now() < end_s:
            self.clock.wait_until(end_s)
            if self.receiver is None:
                self.controller_port.receive()  # nobody reads: the frames are lost
                continue
            stamped = self.reader.poll(self.clock.now())
            accepted += [s.value for s in stamped if isinstance(s.value, MovementCommand)]
        return accepted


MADE: list[Link] = []


@pytest.fixture(autouse=True)
def _end_the_last_senders() -> Iterator[None]:
    """The test over, each link's last sender goes as the others did (a crash): its store's
    writer thread ends."""
    yield
    while MADE:
        MADE.pop().signer.store.halt()


def _frames_until_accepted(link: Link, limit: int) -> int:
    """How many periods the controller accepts nothing before it accepts a frame again."""
    for rejected in range(limit):
        if link.send(1):
            return rejected
    raise AssertionError(f"no frame accepted in {limit}")


def test_replay_in_session_is_rejected(tmp_path: Path) -> None:
    link = Link(tmp_path)
    assert len(link.send(100)) == 100
    assert link.reader.auth_failures == {}
    assert link.replay_everything() == []
    assert link.reader.auth_failures[AuthFailure.BAD_MAC] == 100


def test_a_restart_accepts_no_replay_and_resumes_by_itself(tmp_path: Path) -> None:
    for restart in ("controller", "sender", "both"):
        (tmp_path / restart).mkdir()
        link = Link(tmp_path / restart)
        assert len(link.send(50)) == 50
        if restart in ("controller", "both"):
            link.start_controller()
        if restart in ("sender", "both"):
            link.start_sender()
        # The live sender again: it hears the new trip counter in the first period and signs
        # in it; a restarted sender resumes above its bound in the same trip. Nothing lost.
        assert _frames_until_accepted(link, 10) == 0, restart
        assert len(link.send(20)) == 20
        assert link.replay_everything() == [], restart
        assert _frames_until_accepted(link, 100) <= COUNTER_WINDOW  # the replay's misses
        assert len(link.send(20)) == 20


def test_pre_play_across_a_restart_is_rejected(tmp_path: Path) -> None:
    """Signed frames the controller never saw (made while it was down, their counters above
    everything it accepted) are not accepted after it starts: they are of the old trip."""
    link = Link(tmp_path)
    assert len(link.send(50)) == 50
    link.stop_controller()
    before = len(link.recorded)
    link.send(40)  # the sender goes on while the controller is down: recorded, never seen
    pre_played = link.recorded[before:]
    assert len(pre_played) == 80
    link.start_controller()
    assert link.replay(pre_played) == []
    assert link.reader.auth_failures[AuthFailure.BAD_MAC] == 40
    assert _frames_until_accepted(link, 100) <= COUNTER_WINDOW


def test_every_restart_order_in_a_row_never_accepts_a_replay(tmp_path: Path) -> None:
    link = Link(tmp_path)
    for restart in ("controller", "sender", "both", "sender", "controller"):
        link.send(2 * BLOCK)
        if restart != "sender":
            link.stop_controller()
            link.send(3)  # pre-play material
            link.start_controller()
        if restart != "controller":
            link.start_sender()
        assert link.replay_everything() == [], restart
    assert _frames_until_accepted(link, 100) <= COUNTER_WINDOW
    assert len(link.send(20)) == 20
    assert len(set(link.trips)) == len(link.trips)  # no trip counter twice


def test_a_rolled_back_freshness_file_reopens_no_trip(tmp_path: Path) -> None:
    """A copy of the file restored after later starts (a backup, a disk image): the next trip is
    a random step above the copy's, so none of the trips used since comes again and nothing
    recorded in them verifies; the sender, which saw a higher trip, refuses the lower one and
    names the trip to reset to."""
    link = Link(tmp_path)
    link.send(10)
    backup = link.controller_file.read_bytes()
    for _ in range(5):
        link.start_controller()
        link.send(10)
    assert len(link.send(1)) == 1
    link.controller_file.write_bytes(backup)
    link.start_controller()
    assert link.trips[-1] not in link.trips[:-1]
    assert link.replay_everything() == []
    link.send(5)
    assert link.signer.refused_trip == link.trips[-1] < link.signer.store.trip
    assert link.signer.store.trip == max(link.trips[:-1])
