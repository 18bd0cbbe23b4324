"""Both ends of an authenticated command: the sender's signer and the controller's receiver.

The receiver is the freshness master: it holds this start's trip counter (`bywire.security.trip`)
and gives the announcement the controller sends with its reports. The signer takes that
announcement (`hear`, verified, never a lower trip) and gives each command frame its
cryptographic PDU with the next freshness value of that id in that trip (reserved on disk first).
The receiver pairs each command frame with its cryptographic PDU, which must arrive within
`window_s`, and checks the MAC (the acceptance rule: the value rebuilt above the last one
accepted in this trip must verify). Only a verified pair yields the command's payload;
everything else is a failure, named and returned, never a command. Both take `now` from their
caller.
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
from bywire.protocol.secoc import MAX_COUNTER, TRIP_ID, SecocKey
from bywire.security.freshness import Adoption, FreshnessStore

DEFAULT_WINDOW_S = 0.005
PENDING_PER_ID = 2  # command frames of one id waiting for their authenticator
DELIVERY_SLACK_S = 0.020
"""How late a frame may reach the receiver after its arrival stamp (a receive thread, a busy
loop): a command frame waits this much longer than the window before it expires, so that its
PDU, stamped within the window but read a poll later, still pairs (issue 32: in real time the
pairing failed in pairs, PDU without command and command without PDU)."""
TRIP_IDS = frozenset((TRIP_ID, secoc.auth_id(TRIP_ID)))
"""The controller's trip counter announcement and its cryptographic PDU: what `hear` takes."""


class SecocSigner:
    """Makes the cryptographic PDU of each command frame a sender puts on the bus, once the
    controller's trip counter has been heard (`ready`)."""

    def __init__(self, key: SecocKey, store: FreshnessStore) -> None:
        self._key = key
        self.store = store
        self.trip: int | None = None
        """The trip counter verified this session (None: none heard yet)."""
        self.refused_trip: int | None = None
        """The last announced trip below the store's (a replay, or a rolled-back controller)."""
        self.announced_key_check: str | None = None
        """The key check value in the last announcement that did not verify (another key?)."""
        self._next: dict[int, int] = {}
        self._announcement: bytes | None = None

    @property
    def ready(self) -> bool:
        """A trip counter has been heard and taken: commands can be signed."""
        return self.trip is not None

    def hear(self, frame_id: int, data: bytes) -> Adoption | None:
        """Take a frame from the controller: its trip counter announcement (the TripCounter
        frame, then its cryptographic PDU) is verified and adopted. What the adoption was, or
        None for any other frame, or one that does not verify. OSError when a new trip cannot
        be written to the sender's file (it is not taken)."""
        if frame_id == TRIP_ID:
            self._announcement = bytes(data)
            return None
        if frame_id != secoc.auth_id(TRIP_ID) or self._announcement is None:
            return None
        payload, self._announcement = self._announcement, None
        trip = secoc.verified_trip(self._key, payload, bytes(data))
        if trip is None:  # forged, damaged, or the robot has another key (its check value says)
            if len(payload) == secoc.TRIP_PAYLOAD_BYTES:
                announced = secoc.decode_trip(payload).key_check
                if announced != self._key.check_value:
                    self.announced_key_check = announced
            return None
        return self.take_trip(trip)

    def take_trip(self, trip: int) -> Adoption:
        """Sign in `trip` from now on, as a verified announcement of it would (`hear` calls
        this; `bywire frame --trip` with a trip its user read off the bus): refused (LOWER) below
        the trip this sender's file signed in. OSError when a new trip cannot be written."""
        adoption = self.store.adopt(trip)
        if adoption is Adoption.LOWER:
            self.refused_trip = trip
            return adoption
        if adoption is Adoption.NEW or self.trip != trip:
            self._next.clear()
        self.trip, self.refused_trip, self.announced_key_check = trip, None, None
        return adoption

    def next_freshness(self, frame_id: int) -> int | None:
        """The freshness value the next frame of this id will carry (None: not ready)."""
        if self.trip is None:
            return None
        counter = self._next.get(frame_id, self.store.bound(frame_id) + 1)
        return secoc.freshness_value(self.trip, min(counter, MAX_COUNTER))

    def authenticator(self, frame_id: int, payload: bytes) -> CanFrame | None:
        """The cryptographic PDU for this command frame, using up one freshness value; None when
        it cannot be signed now (no trip counter heard, this trip's counters used up, or the
        sender's file cannot be written): the command must not be sent."""
        if self.trip is None:
            return None
        counter = self._next.get(frame_id, self.store.bound(frame_id) + 1)
        if counter > MAX_COUNTER:
            return None
        try:
            self.store.reserve(frame_id, counter)
        except OSError:
            return None
        self._next[frame_id] = counter + 1
        freshness = secoc.freshness_value(self.trip, counter)
        data = secoc.encode_authenticator(self._key, frame_id, payload, freshness)
        return CanFrame(secoc.auth_id(frame_id), data)

    def close(self) -> None:
        self.store.close()


class AuthFailure(enum.Enum):
    """Why a command was not authenticated."""

    NO_AUTHENTICATOR = "no cryptographic PDU within the pairing window"
    BAD_MAC = "MAC does not verify: a forgery, a replay, another key or trip, or a sender behind"
    ORPHAN = "cryptographic PDU without its command frame"
    MALFORMED = "cryptographic PDU of the wrong length"
    EXHAUSTED = "this trip's 2**32 message counters of the id are used up: restart the controller"


class Outcome(NamedTuple):
    """What one received frame led to: a verified command (id, payload) and/or failures."""

    verified: tuple[int, bytes] | None = None
    failures: tuple[tuple[int, AuthFailure], ...] = ()


WAITING = Outcome()  # a command frame held for its cryptographic PDU


class SecocReceiver:
    """The controller's side: pairs, verifies, and keeps the last accepted freshness per id, in
    this start's trip only; it also holds the trip counter's announcement."""

    def __init__(
        self,
        key: SecocKey,
        trip: int,
        command_ids: Iterable[int],
        window_s: float = DEFAULT_WINDOW_S,
    ) -> None:
        self._key = key
        self.trip = trip
        self._window_s = window_s
        self.command_ids = frozenset(command_ids)
        self.crypto_ids = frozenset(secoc.auth_id(i) for i in self.command_ids)
        self.key_check_value = key.check_value
        self.received_ids = self.command_ids | self.crypto_ids
        """Every id this receiver takes: the commands and their cryptographic PDUs."""
        self.announcement = secoc.trip_frames(key, trip)
        """(id, payload) of the trip counter announcement and of its cryptographic PDU: sent with
        every report set, so the senders sign in this trip."""
        self.last_accepted = dict.fromkeys(self.command_ids, secoc.freshness_value(trip, 0))
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
        if secoc.trip_of(freshness) != self.trip:  # past this trip's last message counter
            pending.clear()
            return Outcome(failures=(*stale, (frame_id, AuthFailure.EXHAUSTED)))
        for index in range(len(pending) - 1, -1, -1):  # newest first: it is usually the one
            payload = pending[index][0]
            expected = secoc.truncated_mac(self._key, frame_id, payload, freshness)
            if hmac.compare_digest(expected, authenticator.mac):
                del pending[index]
                self.last_accepted[frame_id] = freshness
                return Outcome(verified=(frame_id, payload), failures=tuple(stale))
        return Outcome(failures=(*stale, (frame_id, AuthFailure.BAD_MAC)))
