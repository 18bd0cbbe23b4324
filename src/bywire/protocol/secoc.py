"""AUTOSAR SecOC profile 3 for classic CAN: the cryptographic PDU beside each command frame.

A command frame (the *authentic PDU*, unchanged: signals, counter, CRC) is followed by a
*cryptographic PDU* on its own id (`AUTH_ID_OFFSET` above the command's), the pair forming a
secured-PDU collection whose message link is the id (albert.dbc's `SecOCAuthenticPdu` attribute)::

    cryptographic PDU, 8 bytes (id = command id + 0x10)
    byte   0        1          2     3     4     5     6     7
         +--------+--------+-----+-----+-----+-----+-----+-----+
         | freshness low   | MAC byte 0 ............ MAC byte 5 |
         | 16 bits, Intel  | first 48 bits of the AES-128 CMAC  |
         +--------+--------+-----+-----+-----+-----+-----+-----+

    MAC = CMAC-AES-128(key, data id (CAN id, 2 bytes big-endian)
                            || authentic payload (every byte, CRC included)
                            || full freshness value (8 bytes big-endian))

Profile 3 ("JASPAR"): 48-bit truncated MAC, 16 low bits of the 64-bit freshness value sent; the
receiver rebuilds the full value as the smallest one above the last it accepted with those low
bits, so it can only move forward. Pure: no I/O, no clock, no state.

The freshness value is AUTOSAR's trip-counter form, with the receiver as freshness master::

    64-bit freshness value = trip counter (32 bits) || message counter (32 bits)

The controller increments its trip counter at every start (persisted before it accepts anything)
and announces it, authenticated, in `TripCounter` (0x206) and its cryptographic PDU (0x216)::

    TripCounter, 7 bytes              TripCounterSecOC, 8 bytes (freshness low 16 bits: 0)
    byte 0..3   trip counter (Intel)  MAC over data id 0x206 || the 7 bytes
    byte 4..6   key check value         || freshness (trip counter << 32)

A sender signs with the announced trip counter and its own message counter for that trip (from 1,
per data id); the controller accepts only its current trip: a frame made before this start,
replayed or pre-played, can never verify.

`cryptography` is imported when a key is made, not with this module: its native core maps 11 MB,
which a robot without `[security]` should not load (nor lock, with `[realtime] lock_memory`).
"""

from __future__ import annotations

import hmac
import struct
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.cmac import CMAC

from bywire.errors import FrameError

KEY_BYTES = 16
MAC_BYTES = 6  # profile 3: 48 bits
FRESHNESS_LOW_BITS = 16  # profile 3: 16 bits sent
FRESHNESS_LOW_MODULUS = 1 << FRESHNESS_LOW_BITS
FRESHNESS_BYTES = 8  # the full value, as it enters the MAC
AUTH_ID_OFFSET = 0x10  # cryptographic PDU id = authentic PDU id + this
AUTH_PDU_BYTES = 2 + MAC_BYTES
DATA_ID_BYTES = 2
COUNTER_BITS = 32  # the message counter: the low half of the freshness value
MAX_TRIP = (1 << 32) - 1
MAX_COUNTER = (1 << COUNTER_BITS) - 1
TRIP_ID = 0x206  # the controller's TripCounter announcement; its cryptographic PDU at +0x10
TRIP_PAYLOAD_BYTES = 7
KEY_CHECK_DIGITS = 6
_DATA_ID = struct.Struct(">H")
_FRESHNESS = struct.Struct(">Q")


class SecocKey:
    """A 128-bit key that never shows itself: its repr and str name only its check value."""

    __slots__ = ("_keyed",)

    def __init__(self, secret: bytes) -> None:
        if len(secret) != KEY_BYTES:
            raise ValueError(f"an AES-128 key is {KEY_BYTES} bytes, got {len(secret)}")
        from cryptography.hazmat.primitives import cmac  # noqa: PLC0415 -- only with a key
        from cryptography.hazmat.primitives.ciphers import algorithms  # noqa: PLC0415

        # Keyed once; each MAC starts from a copy (a fifth of the cost of keying every time).
        self._keyed: CMAC = cmac.CMAC(algorithms.AES128(bytes(secret)))

    def cmac(self, message: bytes) -> bytes:
        """The full 16-byte AES-128 CMAC of `message` (RFC 4493)."""
        mac = self._keyed.copy()
        mac.update(message)
        return mac.finalize()

    @property
    def check_value(self) -> str:
        """6 hex digits that tell two copies of a key apart without revealing it (a KCV)."""
        return self.cmac(b"bywire key check value").hex()[:6].upper()

    def __repr__(self) -> str:
        return f"SecocKey(check value {self.check_value})"

    def __str__(self) -> str:
        # Not `__str__ = __repr__`: compiled, mypyc makes a class-body alias an attribute of
        # every instance, looked up among the module's globals when one is made (KeyError:
        # '__repr__', issue 43; docs/COMPILED.md)
        return repr(self)


def authenticated_data(data_id: int, payload: bytes, freshness: int) -> bytes:
    """What the MAC covers: data id (2 bytes BE) || payload || freshness (8 bytes BE)."""
    return _DATA_ID.pack(data_id) + bytes(payload) + _FRESHNESS.pack(freshness)


def truncated_mac(key: SecocKey, data_id: int, payload: bytes, freshness: int) -> bytes:
    """The first MAC_BYTES bytes of the CMAC over `authenticated_data`."""
    return key.cmac(authenticated_data(data_id, payload, freshness))[:MAC_BYTES]


def auth_id(data_id: int) -> int:
    """The cryptographic PDU's id for a command id (the message link)."""
    return data_id + AUTH_ID_OFFSET


def authentic_id(crypto_id: int) -> int:
    """The command id a cryptographic PDU authenticates."""
    return crypto_id - AUTH_ID_OFFSET


def encode_authenticator(key: SecocKey, data_id: int, payload: bytes, freshness: int) -> bytes:
    """The cryptographic PDU's 8 bytes for one authentic PDU and freshness value."""
    low = freshness % FRESHNESS_LOW_MODULUS
    return low.to_bytes(2, "little") + truncated_mac(key, data_id, payload, freshness)


class Authenticator(NamedTuple):
    """A received cryptographic PDU: the freshness' low bits and the truncated MAC."""

    freshness_low: int
    mac: bytes


def decode_authenticator(data: bytes) -> Authenticator:
    """Split a cryptographic PDU; FrameError when its length is not AUTH_PDU_BYTES."""
    if len(data) != AUTH_PDU_BYTES:
        raise FrameError(f"cryptographic PDU of {len(data)} bytes, expected {AUTH_PDU_BYTES}")
    return Authenticator(data[0] | data[1] << 8, bytes(data[2:]))


def rebuilt_freshness(last_accepted: int, freshness_low: int) -> int:
    """The smallest full freshness value above `last_accepted` whose low bits are these."""
    candidate = (last_accepted & ~(FRESHNESS_LOW_MODULUS - 1)) | freshness_low
    return candidate if candidate > last_accepted else candidate + FRESHNESS_LOW_MODULUS


def verified_freshness(
    key: SecocKey, data_id: int, payload: bytes, authenticator: Authenticator, last_accepted: int
) -> int | None:
    """The acceptance rule: the full freshness value if the MAC verifies with the value rebuilt
    above `last_accepted`, else None (a forgery, a replay or a sender behind the receiver)."""
    freshness = rebuilt_freshness(last_accepted, authenticator.freshness_low)
    expected = truncated_mac(key, data_id, payload, freshness)
    return freshness if hmac.compare_digest(expected, authenticator.mac) else None


# --- the trip counter: the freshness value's high half, owned by the controller ---------------


def freshness_value(trip: int, counter: int) -> int:
    """The 64-bit freshness value of message `counter` (1 and up) in trip `trip`."""
    if not (0 <= trip <= MAX_TRIP and 0 <= counter <= MAX_COUNTER):
        raise ValueError(f"trip {trip} or counter {counter} outside 32 bits")
    return trip << COUNTER_BITS | counter


def trip_of(freshness: int) -> int:
    """The trip counter a freshness value belongs to."""
    return freshness >> COUNTER_BITS


class TripAnnouncement(NamedTuple):
    """The controller's trip counter as announced, with the check value of its key."""

    trip: int
    key_check: str


def trip_frames(key: SecocKey, trip: int) -> tuple[tuple[int, bytes], tuple[int, bytes]]:
    """The announcement of `trip`: (id, payload) of TripCounter and of its cryptographic PDU."""
    payload = trip.to_bytes(4, "little") + int(key.check_value, 16).to_bytes(3, "little")
    pdu = encode_authenticator(key, TRIP_ID, payload, freshness_value(trip, 0))
    return (TRIP_ID, payload), (auth_id(TRIP_ID), pdu)


def decode_trip(payload: bytes) -> TripAnnouncement:
    """A TripCounter payload; FrameError when its length is not TRIP_PAYLOAD_BYTES."""
    if len(payload) != TRIP_PAYLOAD_BYTES:
        raise FrameError(f"TripCounter of {len(payload)} bytes, expected {TRIP_PAYLOAD_BYTES}")
    key_check = int.from_bytes(payload[4:7], "little")
    return TripAnnouncement(int.from_bytes(payload[:4], "little"), f"{key_check:06X}")


def verified_trip(key: SecocKey, payload: bytes, pdu: bytes) -> int | None:
    """The trip counter of an announcement whose MAC verifies with this key, else None."""
    try:
        announced = decode_trip(payload)
        authenticator = decode_authenticator(pdu)
    except FrameError:
        return None
    freshness = freshness_value(announced.trip, 0)
    expected = truncated_mac(key, TRIP_ID, payload, freshness)
    genuine = authenticator.freshness_low == 0 and hmac.compare_digest(expected, authenticator.mac)
    return announced.trip if genuine else None
