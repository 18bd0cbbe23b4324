"""Controllers broken on purpose, for tests that show a check has teeth."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import pytest

from bywire.control import supervisor
from bywire.control.supervisor import Cause
from bywire.model import ControlMode

Latching = Callable[[ControlMode, supervisor.SupervisorInputs], frozenset[Cause]]


def remote_stop_ignored(monkeypatch: pytest.MonkeyPatch) -> Latching:
    """A supervisor whose remote stop stops nothing (its arrival never latches REMOTE_STOP, and
    it no longer counts as CAN-bound): the latching rule to put in `supervisor._latching`."""
    monkeypatch.setattr(supervisor, "CAN_BOUND", frozenset({Cause.CAN_LOST, Cause.CAN_UNTRUSTED}))
    original = supervisor._latching

    def ignoring_arrivals(
        target: ControlMode, inputs: supervisor.SupervisorInputs
    ) -> frozenset[Cause]:
        return original(target, replace(inputs, remote_stop_rising=False))

    return ignoring_arrivals


Debounce = Callable[
    [supervisor.SupervisorState, supervisor.SupervisorInputs, int],
    tuple[ControlMode | None, ControlMode | None, int],
]


def between_taken_for_a_stay() -> Debounce:
    """The debounce before docs/SAFETY.md row 72: a switch read between positions counted as a
    stay at STOP. The rule to put in `supervisor._debounced`."""
    original = supervisor._debounced

    def as_stop(
        state: supervisor.SupervisorState, inputs: supervisor.SupervisorInputs, frames: int
    ) -> tuple[ControlMode | None, ControlMode | None, int]:
        return original(state, replace(inputs, switch_between=False), frames)

    return as_stop


def one_frame_late() -> Debounce:
    """A debounce that counts every move one frame after the robot file says: the rule to put
    in `supervisor._debounced`."""
    original = supervisor._debounced

    def late(
        state: supervisor.SupervisorState, inputs: supervisor.SupervisorInputs, frames: int
    ) -> tuple[ControlMode | None, ControlMode | None, int]:
        return original(state, inputs, frames + 1)

    return late


def can_loss_never_latches(monkeypatch: pytest.MonkeyPatch) -> None:
    """A supervisor for which nothing CAN-bound latches: in CAN mode with the computer silent,
    or its id distrusted, it stays armed (enable high, spring brake released)."""
    monkeypatch.setattr(supervisor, "CAN_BOUND", frozenset())


FromStop = Callable[
    [
        supervisor.SupervisorState,
        supervisor.SupervisorInputs,
        ControlMode | None,
        bool,
        tuple[ControlMode | None, int, bool],
    ],
    supervisor.SupervisorState,
]


def ready_never_reset_at_stop() -> FromStop:
    """A supervisor whose readiness outlives a new stay at STOP (a frame at STOP after the gap
    no longer starts one): the rule to put in `supervisor._from_stop`."""
    original = supervisor._from_stop

    def keeping(
        state: supervisor.SupervisorState,
        inputs: supervisor.SupervisorInputs,
        switch: ControlMode | None,
        held_at_stop: bool,
        debounce: tuple[ControlMode | None, int, bool],
    ) -> supervisor.SupervisorState:
        after = original(state, inputs, switch, held_at_stop, debounce)
        if state.ready and after.mode is ControlMode.STOP and after.switch is ControlMode.STOP:
            return replace(after, ready=True)
        return after

    return keeping


def readied_by_one_frame() -> FromStop:
    """A supervisor that takes one frame at STOP for a stay (the debounce the loader refuses,
    row 26): the rule to put in `supervisor._from_stop`."""
    original = supervisor._from_stop
    stop = ControlMode.STOP

    def one(
        state: supervisor.SupervisorState,
        inputs: supervisor.SupervisorInputs,
        switch: ControlMode | None,
        held_at_stop: bool,
        debounce: tuple[ControlMode | None, int, bool],
    ) -> supervisor.SupervisorState:
        at_stop = switch is stop and debounce[0] is stop and debounce[1] >= 1
        return original(state, inputs, switch, held_at_stop or at_stop, debounce)

    return one
