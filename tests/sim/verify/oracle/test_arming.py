"""The arming tracker alone: the switch held at STOP and moved to a source at zero throttle
arms once the debounce's frames have shown it; what refuses or hides an arming; which source
takes over the steering."""

from __future__ import annotations

from bywire.model import ControlMode
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.checks.h9 import TakeOver
from tests.sim.verify.oracle.parts import TIMING, Parts, parts

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP


def _left_stop_for(mode: ControlMode, at_s: float = 0.5) -> Parts:
    """Held at STOP since power-up, the switch moved to `mode` at `at_s`."""
    p = parts()
    p.arming.set_switch(mode, at_s)
    return p


def test_a_move_from_a_held_stop_arms_once_the_debounce_has_shown_it() -> None:
    p = _left_stop_for(RC)
    assert p.arming.pending is not None
    p.arming.resolve(0.5 + TIMING.settle_s - 0.001)
    assert not p.ledger.armed
    p.arming.resolve(0.5 + TIMING.settle_s)
    assert p.ledger.armed
    assert p.arming.pending is None


def test_a_source_with_its_throttle_pushed_is_not_armed() -> None:
    p = parts()
    p.arming.set_throttle(RC, 0.3, 0.2)
    p.arming.set_switch(RC, 0.5)
    p.arming.resolve(1.0)
    assert not p.ledger.armed


def test_a_stop_too_short_for_the_debounce_s_frames_arms_nothing() -> None:
    p = _left_stop_for(RC)
    p.arming.resolve(1.0)
    p.ledger.request(OracleCause.REMOTE_STOP, 1.0)
    p.arming.set_switch(STOP, 1.5)
    p.arming.set_switch(RC, 1.5 + TIMING.stop_hold_s - 0.001)
    assert p.arming.pending is None


def test_a_fault_in_force_a_while_refuses_an_arming_and_a_can_bound_one_only_into_can() -> None:
    dac = parts()
    dac.faults.note(OracleCause.DAC_FAIL, 0.0)
    dac.arming.arm_now(0.3, RC)  # just begun: whether it refuses is timing
    assert dac.ledger.armed
    dac.ledger.armed = False
    dac.arming.arm_now(0.31, RC)
    assert not dac.ledger.armed
    can = parts()
    can.faults.note(OracleCause.CAN_LOST, 0.0)
    can.arming.arm_now(1.0, CAN)
    assert not can.ledger.armed
    can.arming.arm_now(1.0, RC)
    assert can.ledger.armed


def test_a_re_enable_arms_at_can_unless_something_is_owed_to_the_switch() -> None:
    p = _left_stop_for(CAN)
    p.arming.set_throttle(CAN, 0.3, 0.51)  # changed within the debounce: timing; then pushed
    p.ledger.armed = False
    p.arming.re_enable(1.0)
    assert p.ledger.armed
    assert p.arming.taking == TakeOver(CAN, 1.0 + TIMING.settle_s)
    p.ledger.request(OracleCause.REMOTE_STOP, 1.5)
    p.ledger.owed[OracleCause.WATCHDOG] = 1.6
    p.arming.re_enable(2.0)
    assert not p.ledger.armed


def test_a_re_enable_at_rc_arms_nothing() -> None:
    p = _left_stop_for(RC)
    p.arming.re_enable(2.0)
    assert not p.ledger.armed


def test_a_source_not_at_zero_when_the_switch_moves_to_it_is_not_seen_at_zero() -> None:
    p = _left_stop_for(RC)
    p.arming.resolve(1.0)
    p.arming.set_throttle(CAN, 0.2, 1.0)
    p.arming.set_switch(CAN, 2.0)
    assert not p.arming.sources[CAN].seen_zero
    p.arming.set_throttle(CAN, 0.0, 2.1)
    assert p.arming.sources[CAN].seen_zero


def test_a_source_that_takes_over_is_judged_until_it_steers_anew() -> None:
    p = _left_stop_for(RC)
    assert p.arming.taking == TakeOver(RC, 0.5 + TIMING.settle_s)
    p.arming.set_steering(CAN, 0.5)  # the other source: still judged
    assert p.arming.taking is not None
    p.arming.set_steering(RC, 0.5)
    assert p.arming.taking is None


def test_back_to_a_source_within_the_debounce_is_no_take_over() -> None:
    p = _left_stop_for(RC)
    p.arming.resolve(1.0)
    p.arming.set_switch(CAN, 2.0)
    p.arming.set_switch(RC, 2.0 + TIMING.settle_s - 0.001)
    assert p.arming.taking is None


def test_a_glimpse_of_stop_no_frame_showed_leaves_the_robot_armed() -> None:
    p = _left_stop_for(RC)
    p.arming.resolve(1.0)
    p.arming.set_switch(STOP, 2.0)
    assert not p.ledger.armed
    p.arming.set_switch(RC, 2.0 + TIMING.unseen_s - 0.001)
    assert p.ledger.armed
    seen = _left_stop_for(RC)
    seen.arming.resolve(1.0)
    seen.arming.set_switch(STOP, 2.0)
    seen.arming.set_switch(RC, 2.0 + TIMING.unseen_s + 0.001)
    assert not seen.ledger.armed


def test_a_link_lost_before_the_move_showed_hides_it_until_the_link_is_back() -> None:
    p = _left_stop_for(RC)
    p.arming.link(True, 0.51)
    assert p.arming.settled_s() == float("inf")
    p.arming.link(False, 2.0)
    assert p.arming.settled_s() == 2.0 + TIMING.settle_s


def test_leaving_stop_clears_what_the_switch_acknowledged() -> None:
    p = parts()
    p.ledger.owed[OracleCause.RC_LINK_LOST] = 0.1
    p.arming.set_switch(RC, 0.5)
    assert p.ledger.owed == {}


def test_a_bouncing_switch_s_stop_is_due_from_its_first_stop_frame() -> None:
    # Of `frames` bouncing frames the last reads STOP: an even count starts with one at the
    # switch's own position, so its first STOP frame goes out a frame later (merge31: a drawn
    # robot with 19.6 ms frames and 200 Hz tasks stopped on that frame's next pass).
    def deadline_after(frames: int) -> float | None:
        p = _left_stop_for(RC)
        p.arming.resolve(1.0)
        p.arming.chatter(frames, 2.0)
        return p.ledger.deadline_s

    odd, even = deadline_after(7), deadline_after(8)
    assert odd == 2.0 + TIMING.deadline_s(OracleCause.SWITCH_STOP)
    assert even is not None
    assert odd is not None
    assert abs(even - (odd + TIMING.frame_s)) < 1e-12


def test_a_switch_between_positions_is_stop_without_a_stay() -> None:
    """Row 72: a rest between positions is STOP, but readies no arming; a hold at the STOP
    position before it still counts (the controller's readiness outlives the gap), and so does
    one a glimpse of a source no frame showed did not end."""
    from_source = _left_stop_for(RC)
    from_source.arming.resolve(1.0)
    from_source.arming.set_between(2.0)
    assert from_source.arming.switch is STOP
    from_source.arming.set_switch(RC, 3.5)
    assert from_source.arming.pending is None  # 1.5 s between positions: no hold, no arming
    held = parts()
    held.arming.set_between(1.0)  # from a hold at STOP since 0
    held.arming.set_switch(RC, 2.0)
    assert held.arming.pending is not None
    glimpse = parts()
    glimpse.arming.set_switch(RC, 1.0)
    glimpse.arming.set_between(1.0 + TIMING.unseen_s / 2)
    glimpse.arming.set_switch(RC, 2.0)
    assert glimpse.arming.pending is not None
    flicked = parts()
    flicked.arming.set_between(1.0)
    flicked.arming.set_switch(STOP, 1.5)  # at the STOP position again: a new hold
    flicked.arming.set_switch(RC, 1.5 + TIMING.stop_hold_s - 0.001)
    assert flicked.arming.pending is None
