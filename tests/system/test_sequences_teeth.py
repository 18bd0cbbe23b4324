"""The sequence check has teeth: each old behaviour of issue 10, put back by monkeypatch, is found
by `test_sequences.check_sequences` within its default budget (without shrinking, to stay fast:
the failing example itself is what matters here)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest

from bywire.control import supervisor
from bywire.control.supervisor import DRIVING_MODES, SupervisorState
from bywire.model import ControlMode
from bywire.runtime import actuators, readers, write_gate
from tests.system.test_sequences import check_sequences


def found() -> bool:
    try:
        check_sequences(shrink=False)
    except AssertionError:
        return True
    return False


def test_row_3_a_refused_arming_that_is_remembered_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = supervisor._from_stop

    def remembering(state: SupervisorState, inputs: Any, switch: Any, *rest: Any) -> Any:
        retry = state.ready and switch in DRIVING_MODES
        pretend = replace(state, switch=ControlMode.STOP) if retry else state
        after = original(pretend, inputs, switch, *rest)
        return replace(after, ready=True) if retry and after.mode is ControlMode.STOP else after

    monkeypatch.setattr(supervisor, "_from_stop", remembering)
    assert found()


def test_row_4_a_handover_without_the_throttle_gate_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(
        SupervisorState,
        "throttle_allowed",
        property(lambda self: self.mode is not ControlMode.STOP),
    )
    assert found()


def test_row_6_no_debounce_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(supervisor.SupervisorConfig, "__init__", _debounce_of_one)
    assert found()


def _debounce_of_one(self: supervisor.SupervisorConfig, debounce_frames: int = 1) -> None:
    object.__setattr__(self, "debounce_frames", 1)


def test_row_7_counting_only_consecutive_dac_failures_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(actuators, "DAC_LEAK", 1.0)  # one good write wipes the count
    assert found()


def test_row_8_a_write_in_flight_that_lands_after_the_trip_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def unchecked(self: write_gate.WriteGate, port: str, action: Any) -> bool:
        if self.tripped:
            return False
        action()  # lands after the trip, and stands
        return True

    monkeypatch.setattr(write_gate.WriteGate, "write", unchecked)
    assert found()


def test_row_12_a_leaky_counter_that_half_an_impostor_balances_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def leaky(self: readers._CounterTrust, miss: bool) -> None:
        level = getattr(self, "level", 0) + (1 if miss else -1)
        self.level = max(level, 0)  # type: ignore[attr-defined]
        self.untrusted = self.level >= 3

    monkeypatch.setattr(readers._CounterTrust, "record", leaky)
    assert found()
