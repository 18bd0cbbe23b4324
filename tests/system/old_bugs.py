"""Old behaviours of issue 10, each put back by monkeypatch: the checks must find every one.

Each function takes pytest's `monkeypatch` and re-introduces one safety bug that the hazard
table (docs/SAFETY.md) names by its row; `bywire verify`'s tests (`tests/sim/test_verify.py`,
`tests/cli/test_verify.py`) put each back and find it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest

from bywire.control import controller, supervisor
from bywire.control.supervisor import DRIVING_MODES, SupervisorState
from bywire.model import ControlMode
from bywire.runtime import actuators, readers, write_gate

OldBug = Callable[[pytest.MonkeyPatch], None]


def row_23_a_can_re_enable_clears_every_cause(monkeypatch: pytest.MonkeyPatch) -> None:
    # Issue 10 row 1: the computer's re-enable cleared what only the operator may (a lost RC
    # link, failing DAC writes, a watchdog trip), and the robot drove on.
    monkeypatch.setattr(supervisor, "CAN_CLEARABLE", frozenset(supervisor.Cause))


def row_3_a_refused_arming_is_remembered(monkeypatch: pytest.MonkeyPatch) -> None:
    original = supervisor._from_stop

    def remembering(state: SupervisorState, inputs: Any, switch: Any, *rest: Any) -> Any:
        retry = state.ready and switch in DRIVING_MODES
        pretend = replace(state, switch=ControlMode.STOP) if retry else state
        after = original(pretend, inputs, switch, *rest)
        return replace(after, ready=True) if retry and after.mode is ControlMode.STOP else after

    monkeypatch.setattr(supervisor, "_from_stop", remembering)


def row_4_a_handover_without_the_throttle_gate(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(
        SupervisorState,
        "throttle_allowed",
        property(lambda self: self.mode is not ControlMode.STOP),
    )


def row_6_no_debounce(monkeypatch: pytest.MonkeyPatch) -> None:
    original, one_frame = supervisor.supervisor_step, supervisor.SupervisorConfig(1)

    def undebounced(state: SupervisorState, inputs: Any, _config: Any) -> SupervisorState:
        return original(state, inputs, one_frame)

    monkeypatch.setattr(controller, "supervisor_step", undebounced)


def row_7_only_consecutive_dac_failures_count(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(actuators, "DAC_LEAK", 1.0)  # one good write wipes the count


def row_8_a_write_in_flight_lands_after_the_trip(monkeypatch: pytest.MonkeyPatch) -> None:
    def unchecked(self: write_gate.WriteGate, port: str, action: Any) -> bool:
        if self.tripped:
            return False
        action()  # lands after the trip, and stands
        return True

    monkeypatch.setattr(write_gate.WriteGate, "write", unchecked)


def row_12_a_leaky_counter_half_an_impostor_balances(monkeypatch: pytest.MonkeyPatch) -> None:
    levels: dict[int, int] = {}  # by id(): each trust keeps its own leaky level

    def leaky(self: readers._CounterTrust, miss: bool) -> None:
        levels[id(self)] = max(levels.get(id(self), 0) + (1 if miss else -1), 0)
        self.untrusted = levels[id(self)] >= 3

    monkeypatch.setattr(readers._CounterTrust, "record", leaky)


OLD_BUGS: dict[str, OldBug] = {
    bug.__name__: bug
    for bug in (
        row_23_a_can_re_enable_clears_every_cause,
        row_3_a_refused_arming_is_remembered,
        row_4_a_handover_without_the_throttle_gate,
        row_6_no_debounce,
        row_7_only_consecutive_dac_failures_count,
        row_8_a_write_in_flight_lands_after_the_trip,
        row_12_a_leaky_counter_half_an_impostor_balances,
    )
}
