"""The receiver's pairing rule on its own: the window, orphans, malformed PDUs, displacement."""

from __future__ import annotations

from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.security.freshness import FreshnessStore
from bywire.security.session import DELIVERY_SLACK_S, AuthFailure, SecocReceiver, SecocSigner

KEY = SecocKey(bytes(range(16)))
MOVEMENT = 0x101


def _ends(window_s: float = 0.005) -> tuple[SecocSigner, SecocReceiver]:
    signer = SecocSigner(KEY, FreshnessStore(KEY))
    return signer, SecocReceiver(KEY, FreshnessStore(KEY), dbc.command_ids(), window_s)


def test_a_pair_within_the_window_verifies_and_moves_the_freshness_on() -> None:
    signer, receiver = _ends()
    payload = bytes(8)
    auth = signer.authenticator(MOVEMENT, payload)
    assert receiver.offer(MOVEMENT, payload, 1.000).verified is None  # waits for its PDU
    outcome = receiver.offer(auth.arbitration_id, auth.data, 1.004)
    assert (outcome.verified, outcome.failures) == ((MOVEMENT, payload), ())
    assert receiver.last_accepted[MOVEMENT] == 1


def test_a_pdu_later_than_the_window_leaves_the_command_rejected() -> None:
    signer, receiver = _ends(window_s=0.005)
    payload = bytes(8)
    auth = signer.authenticator(MOVEMENT, payload)
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
    auth = signer.authenticator(MOVEMENT, payload)
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
    auth = signer.authenticator(MOVEMENT, genuine)
    receiver.offer(MOVEMENT, genuine, 0.0)
    receiver.offer(MOVEMENT, forged, 0.001)  # an impostor's frame, no key
    outcome = receiver.offer(auth.arbitration_id, auth.data, 0.002)
    assert outcome.verified == (MOVEMENT, genuine)
    assert receiver.expire(0.1) == [(MOVEMENT, AuthFailure.NO_AUTHENTICATOR)]  # the forged one


def test_a_pdu_for_another_id_does_not_verify() -> None:
    signer, receiver = _ends()
    payload = bytes(3)
    auth = signer.authenticator(0x100, payload)
    receiver.offer(0x102, payload, 0.0)
    moved = receiver.offer(0x112, auth.data, 0.001)  # ControlCommand's PDU under Lights' id
    assert moved.failures == ((0x102, AuthFailure.BAD_MAC),)
