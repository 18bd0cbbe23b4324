"""The supervisor's rules, one table row at a time; `tests/sim/verify/test_supervisor_exhaustive.py`
checks them on every reachable state, and `tests/system/test_sequences.py` on the whole simulated
robot."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.config.limits import DEBOUNCE_FRAMES
from bywire.control.supervisor import (
    CAUSE_FLAGS,
    Cause,
    SupervisorConfig,
    SupervisorInputs,
    SupervisorState,
    counting,
    supervisor_step,
)
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode

STOP, RC, CAN = ControlMode.STOP, ControlMode.RC, ControlMode.CAN
CONFIG = SupervisorConfig(debounce_frames=3)
FRESH = frozenset[Cause]()


def frame(
    switch: ControlMode, conditions: frozenset[Cause] = FRESH, **changes: bool
) -> SupervisorInputs:
    """One new plausible RC frame; CAN fresh with zero throttle unless told otherwise."""
    values: dict[str, bool] = {"rc_throttle_zero": True, "can_throttle_zero": True}
    values.update(changes)
    return SupervisorInputs(conditions, switch, rc_frame=True, **values)


def lost(*causes: Cause) -> SupervisorInputs:
    return SupervisorInputs(frozenset(causes) | {Cause.RC_LOST})


def run(
    state: SupervisorState, *steps: SupervisorInputs, config: SupervisorConfig = CONFIG
) -> SupervisorState:
    for inputs in steps:
        state = supervisor_step(state, inputs, config)
    return state


def frames(count: int, switch: ControlMode, **changes: bool) -> list[SupervisorInputs]:
    return [frame(switch, FRESH, **changes)] * count


def between_frames(switch: ControlMode, **changes: bool) -> SupervisorInputs:
    """A step with no new RC frame: the newest frame still shows `switch`."""
    return replace(frame(switch, FRESH, **changes), rc_frame=False)


def armed(mode: ControlMode = RC) -> SupervisorState:
    return run(SupervisorState(), *frames(3, STOP), *frames(3, mode))


def test_power_up_is_stop_latched_until_the_switch_is_held_at_stop_then_moved() -> None:
    state = run(SupervisorState(), *frames(5, RC))
    assert (state.mode, state.latched) == (STOP, frozenset({Cause.POWER_UP}))
    state = run(state, *frames(2, STOP))
    assert state.latched == {Cause.POWER_UP}  # two frames at STOP are not yet a position
    state = run(state, frame(STOP))
    assert (state.mode, state.latched, state.ready) == (STOP, frozenset(), True)
    state = run(state, *frames(2, RC))
    assert state.mode is STOP  # the debounce: three frames at RC
    assert run(state, frame(RC)).mode is RC


def test_a_switch_between_positions_stops_at_once_but_readies_no_arming() -> None:
    """docs/SAFETY.md row 72 (S11): read between positions, the switch is STOP at once, but no
    stay at STOP, however long it rests there: a flick through STOP shorter than the debounce
    then arms nothing; a stay at the STOP position does. A move out of a stay at STOP through
    the gap between positions keeps the arming ready."""
    gap = frame(STOP, switch_between=True)
    state = run(armed(), gap)
    assert state.mode is STOP
    resting = run(state, *[gap] * 20)
    assert not resting.ready
    flicked = run(resting, frame(STOP), *frames(3, RC))
    assert flicked.mode is STOP  # one frame at STOP: no stay, no arming
    assert run(resting, *frames(3, STOP), *frames(3, RC)).mode is RC
    moved = run(SupervisorState(), *frames(3, STOP), gap, gap, *frames(3, RC))
    assert moved.mode is RC  # from STOP to RC through the gap: still the operator's arming
    # resting there, a repeated frame is no step of the debounce: the controller skips it
    assert not counting(resting, CONFIG)
    assert counting(run(resting, frame(STOP)), CONFIG)


def test_a_move_to_stop_acts_at_once() -> None:
    state = run(armed(), frame(STOP))
    assert state.mode is STOP


def test_a_chattering_switch_stops_once_and_never_rearms() -> None:
    """Hazard row 6: STOP/RC bouncing every frame: one stop, no toggling."""
    state, modes = armed(), []
    for index in range(60):
        state = run(state, frame(STOP if index % 2 == 0 else RC))
        modes.append(state.mode)
    assert modes == [STOP] * 60


@pytest.mark.parametrize(
    "cause", [Cause.RC_IMPLAUSIBLE, Cause.DAC_FAULT, Cause.HYDRO_PRESSURE, Cause.STEERING_ENCODER]
)
def test_a_fault_latches_in_any_mode_and_the_switch_clears_it_once_gone(cause: Cause) -> None:
    switch = None if cause is Cause.RC_IMPLAUSIBLE else RC
    state = run(armed(), SupervisorInputs(frozenset({cause}), switch, rc_frame=True))
    assert (state.mode, state.latched) == (STOP, frozenset({cause}))
    state = run(state, *frames(3, RC))
    assert state.mode is STOP  # the fault is gone, but nobody re-armed
    still = run(state, *[frame(STOP, frozenset({cause}))] * 3)
    if cause is not Cause.RC_IMPLAUSIBLE:
        assert still.latched == {cause}  # held at STOP while the condition still holds
    state = run(state, *frames(3, STOP), *frames(3, RC))
    assert state.mode is RC


def test_latched_causes_are_a_set_and_can_clears_only_its_own() -> None:
    """Hazard row 1: an RC loss, then a CAN-caused latch, then a CAN re-enable edge."""
    state = run(armed(CAN), lost())
    assert state.latched == {Cause.RC_LOST}
    state = run(state, frame(CAN, remote_stop_rising=True))
    assert state.latched == {Cause.RC_LOST, Cause.REMOTE_STOP}
    state = run(state, frame(CAN, re_enable_edge=True))
    assert state.mode is STOP
    assert state.latched == {Cause.RC_LOST, Cause.REMOTE_STOP}  # refused: nothing cleared


def test_the_flags_name_every_latched_cause() -> None:
    state = run(armed(CAN), lost(), frame(CAN, remote_stop_rising=True))
    assert state.flags == ErrorFlag.RC_TIMEOUT | ErrorFlag.REMOTE_STOP
    assert len(set(CAUSE_FLAGS.values())) == len(Cause)


def test_a_can_re_enable_edge_clears_a_can_loss_in_can_mode() -> None:
    state = run(armed(CAN), frame(CAN, frozenset({Cause.CAN_LOST}), can_throttle_zero=False))
    assert state.latched == {Cause.CAN_LOST}
    assert run(state, frame(CAN)).mode is STOP  # fresh commands alone do not clear it
    assert run(state, frame(CAN, re_enable_edge=True)).mode is CAN


def test_a_refused_arming_is_forgotten() -> None:
    """Hazard row 3: refused for a pushed throttle, it neither clears nor arms later."""
    state = run(armed(CAN), frame(CAN, frozenset({Cause.CAN_LOST}), can_throttle_zero=False))
    refused = run(state, frame(CAN, re_enable_edge=True, can_throttle_zero=False))
    assert (refused.mode, refused.latched) == (STOP, frozenset({Cause.CAN_LOST}))
    assert run(refused, *frames(10, CAN)).mode is STOP
    at_stop = run(SupervisorState(), *frames(3, STOP))
    pushed = run(at_stop, *frames(3, RC, rc_throttle_zero=False))
    assert (pushed.mode, pushed.ready) == (STOP, False)
    assert run(pushed, *frames(10, RC)).mode is STOP  # the stick released: still STOP
    assert run(pushed, *frames(3, STOP), *frames(3, RC)).mode is RC


def test_handover_gates_the_throttle_until_the_new_source_is_seen_at_zero() -> None:
    """Hazard row 4: RC → CAN while the computer commands throttle."""
    state = run(armed(RC), *frames(3, CAN, can_throttle_zero=False))
    assert state.mode is CAN
    assert not state.throttle_allowed
    state = run(state, frame(CAN, can_throttle_zero=False))
    assert not state.throttle_allowed
    state = run(state, frame(CAN), frame(CAN, can_throttle_zero=False))
    assert state.throttle_allowed  # seen at zero once: it may drive from then on
    back = run(state, *frames(3, RC, rc_throttle_zero=False))
    assert (back.mode, back.throttle_allowed) == (RC, False)


def test_a_held_remote_stop_stops_can_mode_but_never_locks_the_rc_operator_out() -> None:
    """Hazard row 5."""
    held = frozenset({Cause.REMOTE_STOP})
    state = run(armed(CAN), frame(CAN, held, remote_stop_rising=True))
    assert (state.mode, state.latched) == (STOP, frozenset({Cause.REMOTE_STOP}))
    state = run(state, *[frame(STOP, held)] * 3, *[frame(RC, held)] * 3)
    assert state.mode is RC  # through STOP into RC: the operator takes over
    assert run(state, *[frame(RC, held)] * 10).mode is RC
    to_can = run(state, *[frame(STOP, held)] * 3, *[frame(CAN, held)] * 3)
    assert (to_can.mode, to_can.latched) == (STOP, frozenset({Cause.REMOTE_STOP}))


def test_a_new_remote_stop_stops_rc_mode_too() -> None:
    state = run(armed(RC), frame(RC, frozenset({Cause.REMOTE_STOP}), remote_stop_rising=True))
    assert (state.mode, state.latched) == (STOP, frozenset({Cause.REMOTE_STOP}))


def test_an_untrusted_can_id_stops_can_mode_and_only_the_operator_clears_it() -> None:
    untrusted = frozenset({Cause.CAN_UNTRUSTED})
    state = run(armed(CAN), frame(CAN, untrusted))
    assert state.latched == {Cause.CAN_UNTRUSTED}
    assert run(state, frame(CAN, re_enable_edge=True)).mode is STOP
    assert run(armed(RC), *[frame(RC, untrusted)] * 5).mode is RC  # RC does not care


def test_a_watchdog_trip_is_acknowledged_at_stop_even_though_the_shell_still_holds_it() -> None:
    tripped = frozenset({Cause.WATCHDOG})
    state = run(armed(), frame(RC, tripped))
    assert state.latched == {Cause.WATCHDOG}
    state = run(state, *[frame(STOP, tripped)] * 3)
    assert state.latched == frozenset()  # acknowledged: the shell resets its watchdog now


def test_losing_rc_forgets_the_switch_and_readiness() -> None:
    state = run(SupervisorState(), *frames(3, STOP))
    assert state.ready
    state = run(state, lost())
    assert (state.switch, state.ready) == (None, False)
    state = run(state, *frames(3, RC))
    assert state.mode is STOP  # the switch was not seen at STOP after the link came back


def test_no_new_frame_changes_no_position() -> None:
    at_stop = run(SupervisorState(), *frames(3, STOP))
    state = run(at_stop, *[replace(frame(RC), rc_frame=False)] * 10)
    assert (state.switch, state.mode) == (STOP, STOP)


def test_the_debounce_is_configuration() -> None:
    with pytest.raises(ValueError, match=r"debounce_frames must be 1\.\.50"):
        SupervisorConfig(debounce_frames=0)
    one = SupervisorConfig(debounce_frames=1)
    state = supervisor_step(SupervisorState(), frame(STOP), one)
    assert supervisor_step(state, frame(RC), one).mode is RC


def test_the_debounce_takes_1_to_50_frames_and_a_robot_file_from_2() -> None:
    def accepted(count: int) -> bool:
        try:
            SupervisorConfig(debounce_frames=count)
        except ValueError:
            return False
        return True

    assert [count for count in range(-1, 60) if accepted(count)] == list(range(1, 51))
    assert list(DEBOUNCE_FRAMES) == list(range(2, 51))  # one frame is no debounce (row 26)
    fifty = SupervisorConfig(debounce_frames=50)
    state = run(SupervisorState(), *frames(50, STOP), *frames(49, RC), config=fifty)
    assert state.mode is STOP  # 49 frames are not yet a position
    assert run(state, frame(RC), config=fifty).mode is RC


def test_with_a_one_frame_debounce_one_frame_at_stop_is_a_hold_when_driving_too() -> None:
    """Rule 4a with `debounce_frames=1`: a single frame at STOP is the switch held there, whether
    the mode was STOP or a driving one, so the next frame at RC arms."""
    one = SupervisorConfig(debounce_frames=1)
    state = run(SupervisorState(), frame(STOP), frame(RC), frame(STOP), config=one)
    assert (state.mode, state.ready) == (STOP, True)
    assert run(state, frame(RC), config=one).mode is RC


@pytest.mark.parametrize("cause", [Cause.CAN_LOST, Cause.CAN_UNTRUSTED])
@pytest.mark.parametrize("ending", ["switch to STOP", "RC link lost"])
def test_a_can_fault_in_the_step_that_ends_can_mode_is_latched_with_the_rest(
    cause: Cause, ending: str
) -> None:
    """Rule 2: a CAN-bound cause latches while the mode is CAN, and it still is CAN in the step
    that stops it; a latched STOP names every cause (hazard row 1: the causes are a set)."""
    fault = frozenset({cause})
    stopping = frame(STOP, fault) if ending == "switch to STOP" else lost(cause)
    state = run(armed(CAN), stopping)
    expected = frozenset({cause} if ending == "switch to STOP" else {cause, Cause.RC_LOST})
    assert (state.mode, state.latched) == (STOP, expected)
    assert state.flags & CAUSE_FLAGS[cause]


def test_an_untrusted_id_seen_as_the_switch_flicks_to_stop_still_needs_the_operator() -> None:
    """Only the operator clears CAN_UNTRUSTED, even when it latched in the step the switch left
    CAN: back at CAN without a hold at STOP, a CAN re-enable edge does not arm."""
    state = run(armed(CAN), frame(STOP, frozenset({Cause.CAN_UNTRUSTED})), *frames(3, CAN))
    assert run(state, frame(CAN, re_enable_edge=True)).mode is STOP
    assert run(state, *frames(3, STOP), *frames(3, CAN)).mode is CAN


def test_a_latched_stop_keeps_the_switch_so_a_re_enable_between_rc_frames_arms() -> None:
    """Rule 1: only RC frames (or a lost link) move the debounced switch, not a latch; rule 4b:
    a re-enable edge counts while the newest frames show the switch settled at CAN, whether or
    not an RC frame arrived in the same step (CAN and RC frames are not synchronised)."""
    state = run(armed(CAN), frame(CAN, frozenset({Cause.CAN_LOST})))
    assert (state.mode, state.switch) == (STOP, CAN)
    assert run(state, between_frames(CAN, re_enable_edge=True)).mode is CAN


def test_after_a_refused_re_enable_a_new_edge_arms_without_a_new_debounce() -> None:
    """Rule 4b: the refused edge is forgotten, but the switch is still settled at CAN, so the
    computer's next deliberate edge (throttle now at zero) arms, with or without an RC frame."""
    state = run(armed(CAN), frame(CAN, frozenset({Cause.CAN_LOST}), can_throttle_zero=False))
    refused = run(state, frame(CAN, re_enable_edge=True, can_throttle_zero=False))
    assert (refused.mode, refused.latched, refused.switch) == (
        STOP,
        frozenset({Cause.CAN_LOST}),
        CAN,
    )
    assert run(refused, between_frames(CAN, re_enable_edge=True)).mode is CAN
    assert run(refused, frame(CAN, re_enable_edge=True)).mode is CAN


def test_a_re_enable_in_the_step_of_a_refused_operator_arming_still_counts() -> None:
    """Both arming events in one step: the operator's is refused, the computer's succeeds."""
    at_can = run(SupervisorState(), *frames(3, STOP), *frames(1, CAN))
    stopped = run(at_can, frame(CAN, frozenset({Cause.REMOTE_STOP}), remote_stop_rising=True))
    state = run(stopped, frame(CAN, re_enable_edge=True))
    assert (state.mode, state.latched) == (CAN, frozenset())


def test_a_hold_at_stop_is_forgotten_by_a_later_bounce_through_stop() -> None:
    """The long sequence search: held at STOP, then the switch bounced on its way to RC; once
    it settled at RC the robot armed on the old hold. Only the latest stay at STOP counts."""
    held = run(SupervisorState(), *frames(3, STOP))
    bounced = run(held, frame(RC), frame(STOP), frame(RC), frame(STOP))
    assert run(bounced, *frames(3, RC)).mode is STOP
    assert run(bounced, *frames(3, STOP), *frames(3, RC)).mode is RC
