"""Authenticated commands: a command frame and its cryptographic PDU are paired by when each
arrived at the port, not by when the loop happened to poll (issue 32, defect 2).

Found: the reader stamped a waiting command frame with the poll's `now` and expired what waited
before offering the frames of this poll, so under load (a 10 ms tick, a 5 ms window) a command
and its PDU read on different polls never paired. The reader now pairs on the frames' arrival
stamps and offers a poll's frames before expiring what waits.
"""

from __future__ import annotations

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.runtime.readers import CanReader
from bywire.security.freshness import FreshnessStore
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.security.trip import IN_MEMORY_TRIP

KEY = SecocKey(bytes(range(16)))


def test_a_pdu_that_arrived_within_the_window_pairs_however_late_the_loop_reads_it() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    sender = bus.attach("hlc", accept_ids=(), tx_mailboxes=8)
    port = bus.attach("bywire", True, accept_ids=dbc.received_ids())
    signer = SecocSigner(KEY, FreshnessStore(KEY, None, 32))
    receiver = SecocReceiver(KEY, IN_MEMORY_TRIP, dbc.command_ids())
    for announced_id, announced in receiver.announcement:  # the trip counter the robot sends
        signer.hear(announced_id, announced)
    reader = CanReader(port, secoc=receiver)
    frame_id, payload = dbc.encode_command(MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, 0))
    sender.send(CanFrame(frame_id, payload))
    clock.advance(0.001)
    assert reader.poll(clock.now()) == []  # the command frame waits for its PDU
    authenticator = signer.authenticator(frame_id, payload)
    assert authenticator is not None
    sender.send(authenticator)  # on the wire ~1.4 ms after the command
    clock.advance(0.009)  # the loop's next tick, 10 ms after the first poll
    accepted = reader.poll(clock.now())
    assert reader.auth_failures == {}
    assert [command.value for command in accepted] == [
        MovementCommand(0.0, 0.1, 0.0, Gear.FORWARD, 0)
    ]
