"""What may delay the controller: blind stretches of lost frames and the loop's hang."""

from __future__ import annotations

from bywire.model import ControlMode
from bywire.sim.verify.oracle.delays import Delays
from tests.sim.verify.oracle.parts import TIMING

PERIOD_S = TIMING.control_period_s


def test_a_deadline_a_hang_overlaps_moves_past_it_and_others_stay() -> None:
    delays = Delays(TIMING)
    delays.hang(1.0, 1.1)
    assert delays.past_hang(0.5, 0.9) == 0.9  # done before the hang
    assert delays.past_hang(1.2, 1.3) == 1.3  # begun after it
    assert delays.past_hang(0.95, 1.05) == 1.1 + 2 * PERIOD_S
    delays.write_lag_s = 0.01  # crawling transfers: every deadline that much later
    assert delays.past_hang(0.5, 0.9) == 0.9 + 0.01


def test_a_new_blind_stretch_starts_afresh_and_an_overlapping_one_extends() -> None:
    delays = Delays(TIMING)
    delays.blind(ControlMode.RC, 1.0, 1.1)
    delays.blind(ControlMode.RC, 1.05, 1.2)
    assert (delays.rc_blind_from, delays.rc_blind_until) == (1.0, 1.2)
    delays.blind(ControlMode.RC, 2.0, 2.1)
    assert (delays.rc_blind_from, delays.rc_blind_until) == (2.0, 2.1)
    delays.blind(ControlMode.CAN, 3.0, 3.1)
    assert delays.blind_until(ControlMode.CAN) == 3.1
    assert delays.blind_until(ControlMode.RC) == 2.1


def test_frames_all_sent_within_a_blind_stretch_may_all_be_lost() -> None:
    delays = Delays(TIMING)
    delays.blind(ControlMode.RC, 1.0, 1.1)
    assert delays.all_may_be_lost(2, 1.01)
    assert not delays.all_may_be_lost(20, 1.01)  # the last goes out after it
    assert not delays.all_may_be_lost(2, 0.99)  # the first before it


def test_a_position_is_hidden_while_every_frame_since_its_move_may_be_lost() -> None:
    delays = Delays(TIMING)
    delays.blind(ControlMode.RC, 1.0, 1.1)
    assert delays.hidden(1.0, 1.05)
    assert not delays.hidden(1.0, 1.11)
    assert not delays.hidden(0.98 - TIMING.unseen_s, 1.05)  # a frame before it showed it
