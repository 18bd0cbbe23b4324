"""The supervisor checked exhaustively: every reachable state × every abstract input, breadth-
first from power-up, every invariant S1…S11 of docs/SAFETY.md on every transition. Then proof
that the search has teeth: old bugs put back one at a time, each found with its shortest path.

BYWIRE_EXHAUSTIVE=full searches with every cause instead of one for each group of causes with
the same rules (about 4x the states and 3 minutes; the figures are in docs/SAFETY.md).
"""

from __future__ import annotations

import os
from dataclasses import replace

import pytest

from bywire.control import supervisor
from bywire.control.supervisor import Cause, SupervisorConfig, SupervisorState
from bywire.model import ControlMode
from bywire.sim.verify import supervisor_check
from bywire.sim.verify.supervisor_check import (
    INVARIANTS,
    MONITOR_CAUSES,
    SAME_RULES,
    SEARCHED_IN_OWN_RIGHT,
    TRANSITIONS,
    alphabet,
    expand_same_rules,
    explore,
    reduced_causes,
    same_rules,
    transitions_naming,
)
from tests.sim.verify.mutants import between_taken_for_a_stay, remote_stop_ignored

FULL = os.environ.get("BYWIRE_EXHAUSTIVE") == "full"


def test_the_causes_one_stands_for_follow_the_same_rules() -> None:
    assert same_rules(SAME_RULES)
    assert not same_rules({Cause.DAC_FAULT, Cause.WATCHDOG})
    assert not same_rules({Cause.CAN_LOST, Cause.CAN_UNTRUSTED})


@pytest.mark.long
def test_every_reachable_state_keeps_every_invariant(capsys: pytest.CaptureFixture[str]) -> None:
    causes = tuple(cause for cause in Cause if cause is not Cause.POWER_UP)
    inputs = alphabet(causes if FULL else reduced_causes())
    result = explore(inputs, SupervisorConfig())
    with capsys.disabled():
        print(
            f"\nsupervisor exhaustive check: {result.states} states, {len(inputs)} inputs, "
            f"{result.transitions} transitions, {len(INVARIANTS)} invariants on each"
        )
    assert result.violations == []
    assert result.states > 1000
    every_mode_change = {(a, b) for a in ControlMode for b in ControlMode}
    assert result.mode_changes == every_mode_change
    # The transition table `bywire verify` reports coverage of is exactly what is reachable.
    reached = result.labels if FULL else expand_same_rules(result.labels)
    assert reached == set(TRANSITIONS)
    assert len(TRANSITIONS) == len(set(TRANSITIONS))
    if not FULL:
        # Without the causes DAC_FAULT stands for (the monitors' and TIMING) the search reaches
        # every row but those naming them; without the monitors' alone, what a sensorless robot
        # can take.
        stood_for = set(transitions_naming(SAME_RULES - SEARCHED_IN_OWN_RIGHT))
        assert result.labels == set(TRANSITIONS) - stood_for
        # the E-stop is searched in its own right: it latches from RC, CAN and STOP, and clears
        estop_rows = set(transitions_naming({Cause.ESTOP}))
        assert len(estop_rows) == 4
        assert estop_rows <= result.labels
        assert set(transitions_naming(MONITOR_CAUSES)) < stood_for


# --- teeth: the old behaviours, put back, are found ------------------------------------------

SMALL = SupervisorConfig(debounce_frames=1)


def _found(monkeypatch: pytest.MonkeyPatch, name: str, fake: object) -> set[str]:
    monkeypatch.setattr(supervisor, name, fake)
    result = explore(alphabet(reduced_causes()), SMALL, max_violations=1)
    return {violation for violation, _ in result.violations}


def test_a_single_latch_reason_that_a_later_one_overwrites_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = supervisor.supervisor_step

    def overwriting(
        state: SupervisorState, inputs: supervisor.SupervisorInputs, config: SupervisorConfig
    ) -> SupervisorState:
        after = original(state, inputs, config)
        new = sorted(after.latched - state.latched, key=lambda cause: cause.name)
        return replace(after, latched=frozenset(new[:1])) if new else after  # the old mux

    monkeypatch.setattr(supervisor_check, "supervisor_step", overwriting)
    result = explore(alphabet(reduced_causes()), SMALL, max_violations=1)
    assert {name for name, _ in result.violations}


def test_a_refused_arming_that_clears_the_latch_anyway_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = supervisor._from_stop

    def remembering(
        state: SupervisorState,
        inputs: supervisor.SupervisorInputs,
        switch: ControlMode | None,
        held_at_stop: bool,
        debounce: tuple[ControlMode | None, int, bool],
    ) -> SupervisorState:
        after = original(state, inputs, switch, held_at_stop, debounce)
        return replace(after, latched=frozenset()) if after.mode is ControlMode.STOP else after

    assert _found(monkeypatch, "_from_stop", remembering)


def test_arming_without_the_throttle_check_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(supervisor.SupervisorInputs, "throttle_zero", lambda _self, _source: True)
    result = explore(alphabet(reduced_causes()), SMALL, max_violations=1)
    assert {name for name, _ in result.violations} & {"S4", "S5"}


def test_a_can_re_enable_that_clears_every_cause_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(supervisor, "CAN_CLEARABLE", frozenset(Cause))
    assert _found(monkeypatch, "CAN_CLEARABLE", frozenset(Cause))


def test_a_remote_stop_that_locks_out_rc_or_stops_nothing_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert _found(monkeypatch, "_latching", remote_stop_ignored(monkeypatch))


def test_a_switch_between_positions_taken_for_a_stay_at_stop_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The supervisor before row 72: a STOP read between positions counted as a stay."""
    assert _found(monkeypatch, "_debounced", between_taken_for_a_stay()) == {"S11"}


def test_no_debounce_is_found() -> None:
    """The machine without a debounce, checked against the promise of three frames."""
    inputs = alphabet(reduced_causes())
    result = explore(inputs, SMALL, max_violations=1, checked_against=SupervisorConfig())
    assert {name for name, _ in result.violations} & {"S8", "S9"}  # cleared or armed too soon


def test_the_rows_naming_the_monitor_causes_are_the_eight_that_latch_or_clear_them() -> None:
    rows = transitions_naming(MONITOR_CAUSES)
    assert len(rows) == 8
    assert rows == tuple(
        row for row in TRANSITIONS if "HYDRO_PRESSURE" in row or "STEERING_ENCODER" in row
    )
    assert transitions_naming({Cause.WATCHDOG}) == tuple(r for r in TRANSITIONS if "WATCHDOG" in r)


def test_transitions_are_named_from_the_states_alone() -> None:
    powered = SupervisorState()
    armed = SupervisorState(ControlMode.RC, frozenset(), ControlMode.RC, ControlMode.RC, 3)
    assert supervisor_check.transition_labels(powered, powered) == ()
    at_stop = replace(powered, switch=ControlMode.STOP)
    assert supervisor_check.transition_labels(at_stop, armed) == (
        "STOP->RC: armed by the switch",
        "POWER_UP cleared by arming",
    )
    lost = SupervisorState(ControlMode.STOP, frozenset({Cause.RC_LOST}))
    assert supervisor_check.transition_labels(armed, lost) == ("RC->STOP: RC_LOST latched",)
