"""Both ends of an authenticated command: the sender's signer and the controller's receiver.

The signer gives each command frame its cryptographic PDU, with the next freshness value of that
id (reserved on disk first). The receiver pairs each command frame with its cryptographic PDU,
which must arrive within `window_s`, and checks the MAC (`secoc.verified_freshness`, the
acceptance rule: the value rebuilt above the last one accepted must verify). Only a verified
pair yields the command's payload; everything else is a failure, named and returned, never a
command. Both take `now` from their caller.
"""

from __future__ import annotations

import enum
import hmac
from collections import deque
from collections.abc import Iterable
from typing import NamedTuple

from bywire.errors import FrameError
from bywire.hal.ports import CanFrame
from bywire.protocol import secoc
from bywire.protocol.secoc import SecocKey
from bywire.security.freshness import FreshnessStore

DEFAULT_WINDOW_S = 0.005
PENDING_PER_ID = 2  # command frames of one id waiting for their authenticator
DELIVERY_SLACK_S = 0.020
"""How late a frame may reach the receiver after its arrival stamp (a receive thread, a busy
loop): a command frame waits this much longer than the window before it expires, so that its
PDU, stamped within the window but read a poll later, still pairs (issue 32: in real time the
pairing failed in pairs, PDU without command and command without PDU)."""


class SecocSigner:
    """Makes the cryptographic PDU of each command frame a sender puts on the bus."""

    def __init__(self, key: SecocKey, store: FreshnessStore) -> None:
        self._key = key
        self.store = store
        self._next: dict[int, int] = {}

    def next_freshness(self, frame_id: int) -> int:
        """The freshness value the next frame of this id will carry."""
        return self._next.get(frame_id, self.store.bound(frame_id) + 1)

    def authenticator(self, frame_id: int, payload: bytes) -> CanFrame:
        """The cryptographic PDU for this command frame; uses up one freshness value."""
        freshness = self.next_freshness(frame_id)
        self.store.reserve(frame_id, freshness)
        self._next[frame_id] = freshness + 1
        data = secoc.encode_authenticator(self._key, frame_id, payload, freshness)
        return CanFrame(secoc.auth_id(frame_id), data)

    def close(self) -> None:
        self.store.close()


class AuthFailure(enum.Enum):
    """Why a command was not authenticated."""

    NO_AUTHENTICATOR = "no cryptographic PDU within the pairing window"
    BAD_MAC = "MAC does not verify: a forgery, a replay, another key, or a sender behind"
    ORPHAN = "cryptographic PDU without its command frame"
    MALFORMED = "cryptographic PDU of the wrong length"
    UNSAVED = "the freshness file cannot be written: nothing is accepted that a restart could reuse"


class Outcome(NamedTuple):
    """What one received frame led to: a verified command (id, payload) and/or failures."""

    verified: tuple[int, bytes] | None = None
    failures: tuple[tuple[int, AuthFailure], ...] = ()


WAITING = Outcome()  # a command frame held for its cryptographic PDU


class SecocReceiver:
    """The controller's side: pairs, verifies, and keeps the last accepted freshness per id."""

    def __init__(
        self,
        key: SecocKey,
        store: FreshnessStore,
        command_ids: Iterable[int],
        window_s: float = DEFAULT_WINDOW_S,
    ) -> None:
        self._key = key
        self.store = store
        self._window_s = window_s
        self.command_ids = frozenset(command_ids)
        self.crypto_ids = frozenset(secoc.auth_id(i) for i in self.command_ids)
        self.key_check_value = key.check_value
        self.received_ids = self.command_ids | self.crypto_ids
        """Every id this receiver takes: the commands and their cryptographic PDUs."""
        self.last_accepted = {i: store.bound(i) for i in self.command_ids}
        self._pending: dict[int, deque[tuple[bytes, float]]] = {
            i: deque() for i in self.command_ids
        }

    def expire(self, now: float) -> list[tuple[int, AuthFailure]]:
        """Command frames whose authenticator did not come within the window (and the delivery
        slack): failures. Call it after offering every frame read at `now`."""
        failures: list[tuple[int, AuthFailure]] = []
        for frame_id, pending in self._pending.items():
            while pending and now - pending[0][1] > self._window_s + DELIVERY_SLACK_S:
                pending.popleft()
                failures.append((frame_id, AuthFailure.NO_AUTHENTICATOR))
        return failures

    def offer(self, frame_id: int, data: bytes, now: float) -> Outcome:
        """Take one command frame or cryptographic PDU that arrived at `now` (its arrival
        stamp: the two frames of a command pair when the PDU arrived within the window)."""
        pending = self._pending.get(frame_id)
        if pending is None:
            return self._pair(secoc.authentic_id(frame_id), data, now)
        pending.append((bytes(data), now))  # a command frame: it waits for its PDU
        if len(pending) > PENDING_PER_ID:  # displaced without its authenticator
            pending.popleft()
            return Outcome(failures=((frame_id, AuthFailure.NO_AUTHENTICATOR),))
        return WAITING

    def _pair(self, frame_id: int, data: bytes, arrived_at: float) -> Outcome:
        try:
            authenticator = secoc.decode_authenticator(data)
        except FrameError:
            return Outcome(failures=((frame_id, AuthFailure.MALFORMED),))
        pending = self._pending[frame_id]
        stale: list[tuple[int, AuthFailure]] = []
        while pending and arrived_at - pending[0][1] > self._window_s:  # too old to pair
            pending.popleft()
            stale.append((frame_id, AuthFailure.NO_AUTHENTICATOR))
        if not pending:
            return Outcome(failures=(*stale, (frame_id, AuthFailure.ORPHAN)))
        # The acceptance rule (secoc.verified_freshness), the value rebuilt once for every
        # waiting frame: it depends on the PDU and the last accepted value only.
        freshness = secoc.rebuilt_freshness(
            self.last_accepted[frame_id], authenticator.freshness_low
        )
        for index in range(len(pending) - 1, -1, -1):  # newest first: it is usually the one
            payload = pending[index][0]
            expected = secoc.truncated_mac(self._key, frame_id, payload, freshness)
            if hmac.compare_digest(expected, authenticator.mac):
                del pending[index]
                try:
                    self.store.reserve(frame_id, freshness)
                except OSError:
                    return Outcome(failures=((frame_id, AuthFailure.UNSAVED),))
                self.last_accepted[frame_id] = freshness
                return Outcome(verified=(frame_id, payload), failures=tuple(stale))
        return Outcome(failures=(*stale, (frame_id, AuthFailure.BAD_MAC)))

    def close(self) -> None:
        self.store.close()
