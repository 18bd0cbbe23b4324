"""Both ends on their own: the receiver's pairing rule (the window, orphans, malformed PDUs,
displacement) and the trip counter each end holds; the signer takes only a verified announcement
and never a lower trip."""

from __future__ import annotations

import pytest

from bywire.hal.ports import CanFrame
from bywire.protocol import dbc, secoc
from bywire.protocol.secoc import MAX_COUNTER, SecocKey
from bywire.security.freshness import Adoption, FreshnessStore
from bywire.security.session import DELIVERY_SLACK_S, AuthFailure, SecocReceiver, SecocSigner

KEY = SecocKey(bytes(range(16)))
MOVEMENT = 0x101
TRIP = 7


def _ends(window_s: float = 0.005, trip: int = TRIP) -> tuple[SecocSigner, SecocReceiver]:
    signer = SecocSigner(KEY, FreshnessStore(KEY))
    receiver = SecocReceiver(KEY, trip, dbc.command_ids(), window_s)
    _announce(signer, receiver)
    return signer, receiver


def _announce(signer: SecocSigner, receiver: SecocReceiver) -> Adoption | None:
    adoption = None
    for frame_id, data in receiver.announcement:
        adoption = signer.hear(frame_id, data)
    return adoption


def _signed(signer: SecocSigner, frame_id: int, payload: bytes) -> CanFrame:
    authenticator = signer.authenticator(frame_id, payload)
    assert authenticator is not None
    return authenticator


def test_a_pair_within_the_window_verifies_and_moves_the_freshness_on() -> None:
    signer, receiver = _ends()
    payload = bytes(8)
    auth = _signed(signer, MOVEMENT, payload)
    assert receiver.offer(MOVEMENT, payload, 1.000).verified is None  # waits for its PDU
    outcome = receiver.offer(auth.arbitration_id, auth.data, 1.004)
    assert (outcome.verified, outcome.failures) == ((MOVEMENT, payload), ())
    assert receiver.last_accepted[MOVEMENT] == TRIP << 32 | 1


def test_a_pdu_later_than_the_window_leaves_the_command_rejected() -> None:
    signer, receiver = _ends(window_s=0.005)
    payload = bytes(8)
    auth = _signed(signer, MOVEMENT, payload)
    receiver.offer(MOVEMENT, payload, 1.000)
    assert receiver.expire(1.004) == []
    late = receiver.offer(auth.arbitration_id, auth.data, 1.006)  # stamped 6 ms after it
    assert late.verified is None
    assert late.failures == (
        (MOVEMENT, AuthFailure.NO_AUTHENTICATOR),
        (MOVEMENT, AuthFailure.ORPHAN),
    )


def test_a_pdu_stamped_within_the_window_pairs_even_when_read_a_poll_later() -> None:
    # Issue 32: in real time the loop read a command and its PDU in different polls, 10 ms
    # apart, and expired the command first: the pairing failed in pairs, on every command.
    signer, receiver = _ends(window_s=0.005)
    payload = bytes(8)
    auth = _signed(signer, MOVEMENT, payload)
    receiver.offer(MOVEMENT, payload, 1.000)
    assert receiver.expire(1.010) == []  # the poll that read the command
    paired = receiver.offer(auth.arbitration_id, auth.data, 1.001)  # read by the next poll
    assert paired.verified == (MOVEMENT, payload)
    assert paired.failures == ()


def test_a_command_whose_pdu_never_comes_expires_after_the_window_and_the_slack() -> None:
    _, receiver = _ends(window_s=0.005)
    receiver.offer(MOVEMENT, bytes(8), 1.000)
    assert receiver.expire(1.000 + 0.005 + DELIVERY_SLACK_S - 0.001) == []
    assert receiver.expire(1.000 + 0.005 + DELIVERY_SLACK_S + 0.001) == [
        (MOVEMENT, AuthFailure.NO_AUTHENTICATOR)
    ]


def test_a_malformed_pdu_and_a_displaced_command_are_failures() -> None:
    _, receiver = _ends()
    assert receiver.offer(0x111, bytes(7), 0.0).failures == ((MOVEMENT, AuthFailure.MALFORMED),)
    receiver.offer(MOVEMENT, bytes(8), 0.0)
    receiver.offer(MOVEMENT, bytes(8), 0.0)
    third = receiver.offer(MOVEMENT, bytes(8), 0.0)
    assert third.failures == ((MOVEMENT, AuthFailure.NO_AUTHENTICATOR),)


def test_a_frame_slipped_between_a_command_and_its_pdu_does_not_cost_the_command() -> None:
    signer, receiver = _ends()
    genuine, forged = bytes(8), bytes([1] * 8)
    auth = _signed(signer, MOVEMENT, genuine)
    receiver.offer(MOVEMENT, genuine, 0.0)
    receiver.offer(MOVEMENT, forged, 0.001)  # an impostor's frame, no key
    outcome = receiver.offer(auth.arbitration_id, auth.data, 0.002)
    assert outcome.verified == (MOVEMENT, genuine)
    assert receiver.expire(0.1) == [(MOVEMENT, AuthFailure.NO_AUTHENTICATOR)]  # the forged one


def test_a_pdu_for_another_id_does_not_verify() -> None:
    signer, receiver = _ends()
    payload = bytes(3)
    auth = _signed(signer, 0x100, payload)
    receiver.offer(0x102, payload, 0.0)
    moved = receiver.offer(0x112, auth.data, 0.001)  # ControlCommand's PDU under Lights' id
    assert moved.failures == ((0x102, AuthFailure.BAD_MAC),)


def test_a_signer_signs_nothing_before_it_hears_the_trip_counter() -> None:
    signer = SecocSigner(KEY, FreshnessStore(KEY))
    assert not signer.ready
    assert signer.authenticator(MOVEMENT, bytes(8)) is None
    assert _announce(signer, SecocReceiver(KEY, TRIP, dbc.command_ids())) is Adoption.NEW
    assert signer.ready
    assert signer.next_freshness(MOVEMENT) == TRIP << 32 | 1


@pytest.mark.parametrize(
    "damage",
    [
        lambda frames: (frames[0], (frames[1][0], bytes(8))),  # a forged MAC
        lambda frames: ((frames[0][0], b"\x08" + frames[0][1][1:]), frames[1]),  # trip changed
        lambda frames: (frames[1], frames[0]),  # PDU first: no announcement to pair it with
    ],
    ids=["forged-mac", "changed-trip", "out-of-order"],
)
def test_an_announcement_that_does_not_verify_is_not_taken(damage: object) -> None:
    signer = SecocSigner(KEY, FreshnessStore(KEY))
    frames = SecocReceiver(KEY, TRIP, dbc.command_ids()).announcement
    for frame_id, data in damage(frames):  # type: ignore[operator]
        assert signer.hear(frame_id, data) is None
    assert not signer.ready
    assert signer.announced_key_check is None  # our key's check value: no hint of another key


def test_an_announcement_with_another_key_names_its_check_value() -> None:
    other = SecocKey(bytes(16))
    signer = SecocSigner(KEY, FreshnessStore(KEY))
    _announce(signer, SecocReceiver(other, TRIP, dbc.command_ids()))
    assert not signer.ready
    assert signer.announced_key_check == other.check_value


def test_a_new_trip_starts_every_counter_again_and_a_lower_one_is_refused() -> None:
    signer, receiver = _ends(trip=TRIP)
    for _ in range(5):
        _signed(signer, MOVEMENT, bytes(8))
    assert signer.next_freshness(MOVEMENT) == TRIP << 32 | 6
    later = SecocReceiver(KEY, TRIP + 3, dbc.command_ids())
    assert _announce(signer, later) is Adoption.NEW
    assert signer.next_freshness(MOVEMENT) == (TRIP + 3) << 32 | 1
    assert _announce(signer, receiver) is Adoption.LOWER  # the old trip, replayed or rolled back
    assert signer.refused_trip == TRIP
    assert signer.trip == TRIP + 3  # still signs in the higher trip


def test_a_frame_of_another_trip_never_verifies() -> None:
    signer, _ = _ends(trip=TRIP)
    receiver = SecocReceiver(KEY, TRIP + 1, dbc.command_ids())
    auth = _signed(signer, MOVEMENT, bytes(8))
    receiver.offer(MOVEMENT, bytes(8), 0.0)
    assert receiver.offer(auth.arbitration_id, auth.data, 0.001).failures == (
        (MOVEMENT, AuthFailure.BAD_MAC),
    )


def test_the_last_message_counter_of_a_trip_and_none_past_it() -> None:
    """The bound at its edge: counter 2**32 - 1 verifies; the next would be the next trip's
    first value, which no frame of this trip may take (exhausted, not a struct.error)."""
    signer, receiver = _ends(trip=TRIP)
    last = secoc.freshness_value(TRIP, MAX_COUNTER)
    receiver.last_accepted[MOVEMENT] = last - 1
    payload = bytes(8)
    pdu = secoc.encode_authenticator(KEY, MOVEMENT, payload, last)
    receiver.offer(MOVEMENT, payload, 0.0)
    assert receiver.offer(0x111, pdu, 0.001).verified == (MOVEMENT, payload)
    beyond = secoc.encode_authenticator(KEY, MOVEMENT, payload, last + 1)
    receiver.offer(MOVEMENT, payload, 0.002)
    assert receiver.offer(0x111, beyond, 0.003).failures == ((MOVEMENT, AuthFailure.EXHAUSTED),)
    signer._next[MOVEMENT] = MAX_COUNTER + 1
    assert signer.authenticator(MOVEMENT, payload) is None


def test_the_highest_trip_signs_its_last_counter_without_overflow() -> None:
    top = secoc.MAX_TRIP
    signer, receiver = _ends(trip=top)
    receiver.last_accepted[MOVEMENT] = secoc.freshness_value(top, MAX_COUNTER) - 1
    signer._next[MOVEMENT] = MAX_COUNTER
    auth = _signed(signer, MOVEMENT, bytes(8))
    receiver.offer(MOVEMENT, bytes(8), 0.0)
    assert receiver.offer(auth.arbitration_id, auth.data, 0.001).verified is not None
    receiver.offer(MOVEMENT, bytes(8), 0.002)
    assert receiver.offer(auth.arbitration_id, auth.data, 0.003).failures == (
        (MOVEMENT, AuthFailure.EXHAUSTED),  # rebuilt as 2**64: refused before any packing
    )
