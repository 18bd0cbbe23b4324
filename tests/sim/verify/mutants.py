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
