"""SecOC codec: RFC 4493's CMAC vectors, scapy's SecOC on the same input, the acceptance rule."""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.errors import FrameError
from bywire.protocol import secoc

RFC4493_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
RFC4493_MESSAGE = bytes.fromhex(
    "6bc1bee22e409f96e93d7e117393172a"
    "ae2d8a571e03ac9c9eb76fac45af8e51"
    "30c81c46a35ce411e5fbc1191a0a52ef"
    "f69f2445df4f9b17ad2b417be66c3710"
)
RFC4493_VECTORS = [  # (message length, CMAC) from RFC 4493 section 4
    (0, "bb1d6929e95937287fa37d129b756746"),
    (16, "070a16b46b4d4144f79bdd9dd04a287c"),
    (40, "dfa66747de9ae63030ca32611497c827"),
    (64, "51f0bebf7e3b9d92fc49741779363cfe"),
]


@pytest.mark.parametrize(("length", "expected"), RFC4493_VECTORS)
def test_cmac_matches_rfc_4493(length: int, expected: str) -> None:
    key = secoc.SecocKey(RFC4493_KEY)
    assert key.cmac(RFC4493_MESSAGE[:length]).hex() == expected


def _scapy_mac(key: bytes, data_id: int, payload: bytes, freshness: int) -> bytes:
    """scapy's AUTOSAR SecOC (contrib.automotive.autosar) on the same key, id, payload and
    freshness: its `calculate_cmac` takes the secured data and the freshness value."""
    from scapy.contrib.automotive.autosar.secoc import SecOCMixin  # noqa: PLC0415

    class Pdu(SecOCMixin):
        def get_secoc_payload(self) -> bytes:
            return data_id.to_bytes(2, "big") + payload

        def get_secoc_key(self) -> bytes:
            return key

        def get_secoc_freshness_value(self) -> bytes:
            return freshness.to_bytes(8, "big")

    # scapy has no type hints: the call is untyped, its result is the MAC's bytes.
    mac: bytes = Pdu().get_message_authentication_code()  # type: ignore[no-untyped-call]
    return mac


@given(
    key=st.binary(min_size=16, max_size=16),
    data_id=st.integers(0, 0x7FF),
    payload=st.binary(min_size=0, max_size=8),
    freshness=st.integers(0, 2**64 - 1),
)
def test_mac_matches_scapy_secoc(key: bytes, data_id: int, payload: bytes, freshness: int) -> None:
    ours = secoc.truncated_mac(secoc.SecocKey(key), data_id, payload, freshness)
    assert ours == _scapy_mac(key, data_id, payload, freshness)[: secoc.MAC_BYTES]


def test_the_authenticator_carries_the_low_freshness_bits_and_the_mac() -> None:
    key = secoc.SecocKey(RFC4493_KEY)
    payload = bytes.fromhex("0000102700000f5a")
    data = secoc.encode_authenticator(key, 0x101, payload, 0x1_2345)
    assert len(data) == 8
    assert data[:2] == bytes((0x45, 0x23))
    assert data[2:] == _scapy_mac(RFC4493_KEY, 0x101, payload, 0x1_2345)[:6]
    decoded = secoc.decode_authenticator(data)
    assert decoded.freshness_low == 0x2345
    assert secoc.verified_freshness(key, 0x101, payload, decoded, 0x1_2344) == 0x1_2345


def test_the_id_links_the_pdus() -> None:
    assert [secoc.auth_id(i) for i in (0x100, 0x101, 0x102)] == [0x110, 0x111, 0x112]
    assert secoc.authentic_id(0x111) == 0x101


@pytest.mark.parametrize(
    ("last", "low", "rebuilt"),
    [(0, 1, 1), (0x1_FFFE, 0xFFFF, 0x1_FFFF), (0x1_FFFF, 0, 0x2_0000), (5, 5, 0x1_0005)],
)
def test_freshness_is_rebuilt_above_the_last_accepted(last: int, low: int, rebuilt: int) -> None:
    assert secoc.rebuilt_freshness(last, low) == rebuilt


@given(last=st.integers(0, 2**63), low=st.integers(0, 0xFFFF))
def test_a_rebuilt_freshness_always_moves_forward(last: int, low: int) -> None:
    rebuilt = secoc.rebuilt_freshness(last, low)
    assert last < rebuilt <= last + secoc.FRESHNESS_LOW_MODULUS
    assert rebuilt % secoc.FRESHNESS_LOW_MODULUS == low


def test_a_replay_or_a_wrong_key_or_payload_does_not_verify() -> None:
    key = secoc.SecocKey(RFC4493_KEY)
    payload = bytes.fromhex("0000102700000f5a")
    sent = secoc.decode_authenticator(secoc.encode_authenticator(key, 0x101, payload, 40))
    assert secoc.verified_freshness(key, 0x101, payload, sent, 39) == 40
    assert secoc.verified_freshness(key, 0x101, payload, sent, 40) is None  # replayed
    assert secoc.verified_freshness(key, 0x100, payload, sent, 39) is None  # other id
    other = secoc.SecocKey(bytes(16))
    assert secoc.verified_freshness(other, 0x101, payload, sent, 39) is None
    tampered = payload[:-1] + b"\x00"
    assert secoc.verified_freshness(key, 0x101, tampered, sent, 39) is None


def test_a_key_never_shows_itself() -> None:
    key = secoc.SecocKey(RFC4493_KEY)
    for text in (repr(key), str(key), f"{key}"):
        assert RFC4493_KEY.hex() not in text.lower()
        assert key.check_value in text
    with pytest.raises(ValueError, match="16 bytes"):
        secoc.SecocKey(b"short")


def test_keys_made_one_after_another_in_a_fresh_process_all_work() -> None:
    # issue 43: compiled, `__str__ = __repr__` made `__str__` an attribute of every key, looked
    # up among the module's globals as each key was made; its KeyError '__repr__' was left
    # pending and raised by a later call, at random (in most runs once importlib.metadata,
    # which hypothesis imports, was loaded). Fifty keys in a new interpreter of this build.
    script = (
        "import importlib.metadata\n"
        "from bywire.protocol import secoc\n"
        "for _ in range(50):\n"
        f"    key = secoc.SecocKey(bytes.fromhex({RFC4493_KEY.hex()!r}))\n"
        "    print(key.cmac(b'').hex())\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"{RFC4493_VECTORS[0][1]}\n" * 50
    # and `str` is a method of the class, not an attribute of each key
    assert not inspect.isdatadescriptor(vars(secoc.SecocKey)["__str__"])


def test_a_short_authenticator_is_a_frame_error() -> None:
    with pytest.raises(FrameError, match="7 bytes"):
        secoc.decode_authenticator(bytes(7))


def test_the_trip_counter_announcement_is_the_dbcs_and_decodes_with_cantools() -> None:
    """TripCounter and its cryptographic PDU as albert.dbc defines them: ids, lengths, signal
    layout (cantools decodes what the codec encodes) and the message link."""
    from bywire.protocol import dbc  # noqa: PLC0415

    key = secoc.SecocKey(RFC4493_KEY)
    (trip_id, payload), (pdu_id, pdu) = secoc.trip_frames(key, 0x1234_5678)
    database = dbc.database()
    message, crypto = (
        database.get_message_by_name("TripCounter"),
        database.get_message_by_name("TripCounterSecOC"),
    )
    assert (message.frame_id, message.length) == (trip_id, len(payload)) == (0x206, 7)
    assert (crypto.frame_id, crypto.length) == (pdu_id, len(pdu)) == (0x216, 8)
    assert crypto.dbc is not None
    assert crypto.dbc.attributes["SecOCAuthenticPdu"].value == 0x206
    assert message.decode(payload) == {
        "trip_counter": 0x1234_5678,
        "key_check": int(key.check_value, 16),
    }
    decoded = crypto.decode(pdu)
    assert isinstance(decoded, dict)
    assert decoded["freshness_low"] == 0
    assert secoc.verified_trip(key, payload, pdu) == 0x1234_5678
    assert secoc.decode_trip(payload).key_check == key.check_value


@given(trip=st.integers(0, secoc.MAX_TRIP), counter=st.integers(0, secoc.MAX_COUNTER))
def test_the_freshness_value_is_the_trip_then_the_message_counter(trip: int, counter: int) -> None:
    freshness = secoc.freshness_value(trip, counter)
    assert freshness == trip << 32 | counter < 2**64
    assert secoc.trip_of(freshness) == trip


@pytest.mark.parametrize(("trip", "counter"), [(-1, 0), (2**32, 0), (0, 2**32), (0, -1)])
def test_a_trip_or_counter_past_32_bits_is_refused(trip: int, counter: int) -> None:
    with pytest.raises(ValueError, match="outside 32 bits"):
        secoc.freshness_value(trip, counter)
