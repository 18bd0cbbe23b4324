"""Authenticated commands: a command frame and its cryptographic PDU are paired by when each
arrived at the port, not by when the loop happened to poll (issue 32, defect 2).

Found: `CanReader.poll` calls `SecocReceiver.expire(now)` before it offers the frames of this
poll, and `offer` stamps a waiting command frame with the poll's `now`, not the frame's own
arrival stamp. With the default 5 ms pairing window and a 10 ms control tick, a command polled
at once and its PDU that arrived 1.4 ms later but is read at the next tick is dropped
(NO_AUTHENTICATOR), and its PDU then counts as an ORPHAN: in real time, under load, every command
can fail this way (the test course in real time with --authenticated failed 3 of 3 times), while
virtual time, where every arrival wakes the loop at once, passes. The fix belongs to the CAN
reader, which the lead is rewriting (issues 29/30): expire and pair on the frames' arrival
stamps (`arrival(frame, now)`), and offer the poll's frames before expiring what waits.
"""

from __future__ import annotations

import pytest

from bywire.hal.ports import CanFrame
from bywire.hal.sim.can_bus import SimCanBus
from bywire.hal.sim.clock import VirtualClock
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.runtime.readers import CanReader
from bywire.security.freshness import FreshnessStore
from bywire.security.session import SecocReceiver, SecocSigner

KEY = SecocKey(bytes(range(16)))


@pytest.mark.xfail(
    strict=True,
    reason="issue 32 defect 2: SecOC pairing is timed by the loop's poll, not the frames' arrival"
    " (the CAN reader is the lead's, being rewritten)",
)
def test_a_pdu_that_arrived_within_the_window_pairs_however_late_the_loop_reads_it() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    sender = bus.attach("hlc", accept_ids=(), tx_mailboxes=8)
    port = bus.attach("bywire", True, accept_ids=dbc.received_ids())
    signer = SecocSigner(KEY, FreshnessStore(KEY, None, 32))
    reader = CanReader(
        port, secoc=SecocReceiver(KEY, FreshnessStore(KEY, None, 32), dbc.command_ids())
    )
    frame_id, payload = dbc.encode_command(MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, 0))
    sender.send(CanFrame(frame_id, payload))
    clock.advance(0.001)
    assert reader.poll(clock.now()) == []  # the command frame waits for its PDU
    sender.send(signer.authenticator(frame_id, payload))  # on the wire ~1.4 ms after the command
    clock.advance(0.009)  # the loop's next tick, 10 ms after the first poll
    accepted = reader.poll(clock.now())
    assert reader.auth_failures == {}
    assert [command.value for command in accepted] == [
        MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, 0)
    ]
