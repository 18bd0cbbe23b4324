"""Freshness across restarts: the controller, the sender, and both, each crashed (no clean close)
and restarted from their files; every frame ever recorded is then replayed, and none is
accepted; the live sender is accepted again without any manual step.

Real code paths: the CAN reader of the runtime with its SecOC receiver, on the simulated bus, on
virtual time; the freshness files in a temporary directory.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from bywire.hal.ports import CanFrame
from bywire.hal.sim.can_bus import LoggedFrame, SimCanBus
from bywire.hal.sim.clock import VirtualClock
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.runtime.readers import COUNTER_WINDOW, CanReader
from bywire.security.freshness import FreshnessStore
from bywire.security.session import AuthFailure, SecocReceiver, SecocSigner

BLOCK = 8
PERIOD_S = 0.02
KEY = SecocKey(bytes(range(16)))


@dataclass
class Link:
    """A sender and the controller's CAN reader on one simulated bus, with an attacker's port."""

    tmp_path: Path
    clock: VirtualClock = field(default_factory=VirtualClock)
    recorded: list[LoggedFrame] = field(default_factory=list)
    counter: int = 0
    signer: SecocSigner = field(init=False)  # set by start_sender, again at each restart
    receiver: SecocReceiver = field(init=False)  # set by start_controller, likewise

    def __post_init__(self) -> None:
        self.bus = SimCanBus(self.clock)
        self.sender_port = self.bus.attach("hlc", accept_ids=(), tx_mailboxes=8)
        self.attacker = self.bus.attach("attacker", accept_ids=(), tx_mailboxes=100_000)
        self.controller_port = self.bus.attach("bywire", True, accept_ids=dbc.received_ids())
        self.bus.add_monitor(self._record)
        self.start_sender()
        self.start_controller()

    def _record(self, frame: LoggedFrame) -> None:
        if frame.sender == "hlc":
            self.recorded.append(frame)

    def start_sender(self) -> None:
        if hasattr(self, "signer"):
            self.signer.store.halt()  # a crash: nothing pending is written
        store = FreshnessStore(KEY, self.tmp_path / "sender.json", BLOCK)
        self.signer = SecocSigner(KEY, store)  # the old one is dropped: a crash, nothing flushed

    def start_controller(self) -> None:
        if hasattr(self, "receiver"):
            self.receiver.store.halt()
        store = FreshnessStore(KEY, self.tmp_path / "controller.json", BLOCK)
        self.receiver = SecocReceiver(KEY, store, dbc.command_ids())
        self.reader = CanReader(self.controller_port, secoc=self.receiver)
        self.controller_port.receive()  # a restarted process opens a fresh socket

    def send(self, frames: int) -> list[MovementCommand]:
        """The sender's next `frames` movement commands, one period apart; what was accepted."""
        accepted: list[MovementCommand] = []
        for _ in range(frames):
            command = MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, self.counter)
            self.counter = (self.counter + 1) % dbc.COUNTER_MODULUS
            frame_id, payload = dbc.encode_command(command)
            self.sender_port.send(CanFrame(frame_id, payload))
            self.sender_port.send(self.signer.authenticator(frame_id, payload))
            accepted += self._poll_after(PERIOD_S)
        return accepted

    def replay_everything(self) -> list[MovementCommand]:
        """Every frame the sender ever put on the bus, again, from the attacker's port, paced
        as it was sent (each command frame with its cryptographic PDU)."""
        accepted: list[MovementCommand] = []
        recorded = list(self.recorded)
        for authentic, crypto in zip(recorded[::2], recorded[1::2], strict=True):
            self.attacker.send(CanFrame(authentic.arbitration_id, authentic.data))
            self.attacker.send(CanFrame(crypto.arbitration_id, crypto.data))
            accepted += self._poll_after(PERIOD_S)
        return accepted

    def _poll_after(self, duration_s: float) -> list[MovementCommand]:
        end_s = self.clock.now() + duration_s
        accepted: list[MovementCommand] = []
        while self.clock.now() < end_s:
            self.clock.wait_until(end_s)
            stamped = self.reader.poll(self.clock.now())
            accepted += [s.value for s in stamped if isinstance(s.value, MovementCommand)]
        return accepted


def test_an_uninterrupted_link_accepts_every_command_and_no_replay(tmp_path: Path) -> None:
    link = Link(tmp_path)
    assert len(link.send(100)) == 100
    assert link.reader.auth_failures == {}
    assert link.replay_everything() == []
    assert link.reader.auth_failures[AuthFailure.BAD_MAC] == 100


def _frames_until_accepted(link: Link, limit: int) -> int:
    """How many live frames the controller rejects before it accepts one again."""
    for rejected in range(limit):
        if link.send(1):
            return rejected
    raise AssertionError(f"no frame accepted in {limit}")


@pytest.mark.parametrize("restart", ["controller", "sender", "both"])
def test_a_restart_accepts_no_replay_and_resumes_by_itself(tmp_path: Path, restart: str) -> None:
    link = Link(tmp_path)
    assert len(link.send(50)) == 50
    if restart in ("controller", "both"):
        link.start_controller()
    if restart in ("sender", "both"):
        link.start_sender()
    # The live sender again. A restarted sender resumes above every value it may have used: not
    # one frame lost. A restarted controller rejects values up to its reserved bound (at most
    # 1.5 blocks above the last it accepted) until the sender passes it; those failures make the
    # id untrusted until a window of good frames. No manual step either way.
    lost = _frames_until_accepted(link, 100)
    if restart == "sender":
        assert lost == 0
    else:
        assert lost <= BLOCK + BLOCK // 2 + COUNTER_WINDOW
    assert len(link.send(20)) == 20
    assert link.replay_everything() == []
    assert _frames_until_accepted(link, 100) <= COUNTER_WINDOW
    assert len(link.send(20)) == 20


def test_every_restart_order_in_a_row_never_accepts_a_replay(tmp_path: Path) -> None:
    link = Link(tmp_path)
    for restart in ("controller", "sender", "both", "sender", "controller"):
        link.send(2 * BLOCK)
        if restart != "sender":
            link.start_controller()
        if restart != "controller":
            link.start_sender()
        assert link.replay_everything() == [], restart
    assert _frames_until_accepted(link, 100) <= BLOCK + BLOCK // 2 + COUNTER_WINDOW
    assert len(link.send(20)) == 20


def test_freshness_on_disk_always_covers_what_was_used(tmp_path: Path) -> None:
    store = FreshnessStore(KEY, tmp_path / "f.json", BLOCK)
    for value in range(1, 200):
        store.reserve(0x101, value)
        on_disk = json.loads((tmp_path / "f.json").read_text())["bounds"]["257"]
        assert on_disk >= value
        assert on_disk <= value + 2 * BLOCK
    store.close()


def test_a_new_key_starts_its_freshness_afresh(tmp_path: Path) -> None:
    store = FreshnessStore(KEY, tmp_path / "f.json", BLOCK)
    store.reserve(0x101, 1000)
    store.close()
    assert FreshnessStore(KEY, tmp_path / "f.json", BLOCK).bound(0x101) >= 1000
    other = FreshnessStore(SecocKey(bytes(16)), tmp_path / "f.json", BLOCK)
    assert (other.bound(0x101), other.found) == (0, False)


def test_a_damaged_freshness_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "f.json").write_text("{}")
    with pytest.raises(ValueError, match="not a bywire freshness file"):
        FreshnessStore(KEY, tmp_path / "f.json", BLOCK)
