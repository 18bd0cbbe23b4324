"""Control-mode multiplexer: switch selection, no fall-back, latched STOP and re-arming."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.mux import (
    STOPPED,
    Latch,
    MuxInputs,
    MuxState,
    movement_from,
    mux_step,
)
from bywire.control.rc_mapping import RcRequest
from bywire.model import ControlMode, Gear, MovementCommand

RC_IDLE = RcRequest(ControlMode.RC, 0.0, 0.0, 0.0, Gear.FORWARD, low_beam=False, hazard=False)
CAN_MOVE = MovementCommand(0.2, 0.3, 0.0, Gear.FORWARD, counter=1)
CAN_IDLE = MovementCommand(0.2, 0.0, 0.5, Gear.FORWARD, counter=2)
ARMED = MuxState(ControlMode.STOP, latch=None)


def rc(mode: ControlMode, throttle_norm: float = 0.0) -> RcRequest:
    return replace(RC_IDLE, mode=mode, throttle_norm=throttle_norm)


def run(state: MuxState, *steps: MuxInputs) -> MuxState:
    for inputs in steps:
        state = mux_step(state, inputs)
    return state


def test_power_up_is_latched_stop_until_the_switch_passes_through_stop() -> None:
    state = run(MuxState(), MuxInputs(rc(ControlMode.RC), None))
    assert (state.mode, state.latch) == (ControlMode.STOP, Latch.POWER_UP)
    state = run(state, MuxInputs(rc(ControlMode.STOP), None), MuxInputs(rc(ControlMode.RC), None))
    assert (state.mode, state.latch) == (ControlMode.RC, None)


@pytest.mark.parametrize("mode", [ControlMode.STOP, ControlMode.RC, ControlMode.CAN])
def test_switch_selects_the_mode(mode: ControlMode) -> None:
    assert mux_step(ARMED, MuxInputs(rc(mode), CAN_IDLE)).mode is mode


def test_rc_lost_is_latched_stop_even_in_can_mode_with_fresh_can() -> None:
    state = run(ARMED, MuxInputs(rc(ControlMode.CAN), CAN_MOVE), MuxInputs(None, CAN_MOVE))
    assert (state.mode, state.latch) == (ControlMode.STOP, Latch.RC_LOST)
    state = run(state, MuxInputs(rc(ControlMode.CAN), CAN_MOVE))
    assert state.mode is ControlMode.STOP  # RC back, but the operator must re-arm


def test_stale_can_in_can_mode_is_stop_and_never_falls_back_to_rc() -> None:
    state = run(
        ARMED, MuxInputs(rc(ControlMode.CAN), CAN_MOVE), MuxInputs(rc(ControlMode.CAN), None)
    )
    assert (state.mode, state.latch) == (ControlMode.STOP, Latch.CAN_LOST)
    assert movement_from(state.mode, MuxInputs(rc(ControlMode.CAN, 0.9), None)) == STOPPED
    state = run(state, MuxInputs(rc(ControlMode.CAN), CAN_MOVE))
    assert state.mode is ControlMode.STOP  # fresh CAN alone does not unlatch


def test_stale_can_does_not_matter_in_rc_mode() -> None:
    assert mux_step(ARMED, MuxInputs(rc(ControlMode.RC), None)).mode is ControlMode.RC


def test_can_re_enable_edge_clears_a_can_latch() -> None:
    state = run(ARMED, MuxInputs(rc(ControlMode.CAN), None))
    state = run(state, MuxInputs(rc(ControlMode.CAN), CAN_IDLE, re_enable=True))
    assert state.mode is ControlMode.CAN


def test_a_held_re_enable_is_not_an_edge() -> None:
    held = MuxInputs(rc(ControlMode.CAN), CAN_IDLE, re_enable=True)
    state = run(
        ARMED, held, MuxInputs(rc(ControlMode.CAN), CAN_MOVE, remote_stop=True, re_enable=True)
    )
    assert state.latch is Latch.REMOTE_STOP
    assert run(state, held, held).mode is ControlMode.STOP
    released = MuxInputs(rc(ControlMode.CAN), CAN_IDLE)
    assert run(state, released, held).mode is ControlMode.CAN


def test_re_enable_does_not_clear_an_rc_latch() -> None:
    state = MuxState(ControlMode.STOP, latch=Latch.RC_LOST)
    assert (
        mux_step(state, MuxInputs(rc(ControlMode.CAN), CAN_MOVE, re_enable=True)).mode
        is ControlMode.STOP
    )


def test_leaving_stop_needs_zero_throttle_from_the_new_source() -> None:
    state = mux_step(ARMED, MuxInputs(rc(ControlMode.RC, throttle_norm=0.4), None))
    assert (state.mode, state.latch) == (ControlMode.STOP, None)
    assert mux_step(state, MuxInputs(rc(ControlMode.RC), None)).mode is ControlMode.RC
    can_pushing = MuxInputs(rc(ControlMode.CAN), CAN_MOVE)
    assert mux_step(ARMED, can_pushing).mode is ControlMode.STOP


def test_switching_between_live_sources_keeps_driving() -> None:
    state = MuxState(ControlMode.CAN, latch=None)
    assert mux_step(state, MuxInputs(rc(ControlMode.RC, 0.5), CAN_MOVE)).mode is ControlMode.RC


def test_movement_follows_the_selected_source() -> None:
    inputs = MuxInputs(rc(ControlMode.RC, 0.5), CAN_MOVE)
    assert movement_from(ControlMode.RC, inputs).throttle_norm == 0.5
    assert movement_from(ControlMode.CAN, inputs).steering_norm == pytest.approx(0.2)
    assert movement_from(ControlMode.STOP, inputs) == STOPPED
    assert STOPPED.throttle_norm == 0.0
    assert STOPPED.brake_norm == 1.0


modes = st.sampled_from(list(ControlMode))
inputs_strategy = st.builds(
    MuxInputs,
    rc=st.none() | st.builds(rc, modes, st.floats(0.0, 1.0)),
    can_movement=st.none() | st.just(CAN_MOVE),
    remote_stop=st.booleans(),
    re_enable=st.booleans(),
    hardware_fault=st.booleans(),
)


@given(st.lists(inputs_strategy, min_size=1, max_size=30))
def test_never_drives_a_source_that_is_missing_or_not_selected(steps: list[MuxInputs]) -> None:
    state = MuxState()
    for inputs in steps:
        state = mux_step(state, inputs)
        if state.mode is not ControlMode.STOP:
            assert inputs.rc is not None
            assert state.mode is inputs.rc.mode
            assert not inputs.remote_stop
            assert not inputs.hardware_fault
            assert state.mode is ControlMode.RC or inputs.can_movement is not None


def test_hardware_fault_latches_until_the_switch_passes_through_stop() -> None:
    driving = MuxState(ControlMode.RC, latch=None)
    state = mux_step(driving, MuxInputs(rc(ControlMode.RC), None, hardware_fault=True))
    assert (state.mode, state.latch) == (ControlMode.STOP, Latch.HARDWARE_FAULT)
    state = mux_step(state, MuxInputs(rc(ControlMode.CAN), CAN_IDLE, re_enable=True))
    assert state.mode is ControlMode.STOP
    state = run(state, MuxInputs(rc(ControlMode.STOP), None), MuxInputs(rc(ControlMode.RC), None))
    assert state.mode is ControlMode.RC
