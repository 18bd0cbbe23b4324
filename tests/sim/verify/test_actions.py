"""The campaign actions' table: every action, with every value it may take, becomes scenario
events the loader accepts; the ones that follow the switch or the remote stop request write what
an operator or the computer would."""

from __future__ import annotations

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.model import ControlMode
from bywire.sim.scenario import parse_scenario, scenario_toml
from bywire.sim.verify.actions import (
    ACTIONS,
    ARM_HOLD_S,
    HANDOVER_LEAD_S,
    RE_ENABLE_RISE_S,
    VOCABULARY,
    Action,
    compile_steps,
)
from bywire.sim.verify.step_events import Step

ROBOT = default_sim_config()
RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP


def _events(*steps: Step) -> list[tuple[float, str, dict[str, object]]]:
    scenario = compile_steps(steps, ROBOT)
    return [(event.at_s, event.kind, event.values) for event in scenario.events[2:]]


def test_the_vocabulary_is_the_table_s() -> None:
    assert {action.name: action.values for action in ACTIONS} == VOCABULARY
    assert len({action.name for action in ACTIONS}) == len(ACTIONS)


@pytest.mark.parametrize("action", ACTIONS, ids=lambda action: action.name)
def test_every_value_of_every_action_compiles_to_a_scenario_the_loader_accepts(
    action: Action,
) -> None:
    name = action.name
    values = list(VOCABULARY[name])
    values = [values[0], values[-1]] if isinstance(VOCABULARY[name], range) else values
    steps = [Step(0.2, "arm", CAN), *(Step(0.1, name, value) for value in values)]
    scenario = compile_steps(steps, ROBOT)
    loaded = parse_scenario(scenario_toml(scenario), "<compiled>").events
    assert len(loaded) == len(scenario.events) > 2
    for read, written in zip(loaded, scenario.events, strict=True):  # the loader adds defaults
        assert (read.at_s, read.kind) == (written.at_s, written.kind)
        assert read.values.items() >= written.values.items()


def test_arm_holds_the_switch_at_stop_then_moves_it_with_the_source_at_zero() -> None:
    assert _events(Step(0.2, "arm", CAN)) == [
        (0.2, "rc", {"mode": "stop"}),
        (0.2 + ARM_HOLD_S, "hlc", {"throttle": 0.0}),
        (0.2 + ARM_HOLD_S, "rc", {"mode": "can"}),
    ]


def test_a_flick_returns_to_where_the_switch_was_and_from_stop_stays() -> None:
    flicked = _events(Step(0.2, "arm", RC), Step(0.5, "flick", 0.02))
    assert flicked[-2:] == [(0.7, "rc", {"mode": "stop"}), (0.72, "rc", {"mode": "rc"})]
    assert _events(Step(0.2, "flick", 0.02)) == [(0.2, "rc", {"mode": "stop"})]


def test_a_handover_to_can_puts_the_computer_s_set_point_on_the_bus_first() -> None:
    to_can = _events(Step(0.2, "arm", RC), Step(0.5, "handover_steer", 0.9))
    assert to_can[-2:] == [
        (0.7, "hlc", {"steering": 0.9, "throttle": 0.0}),
        (round(0.7 + HANDOVER_LEAD_S, 6), "rc", {"mode": "can"}),
    ]
    to_rc = _events(Step(0.2, "arm", CAN), Step(0.5, "handover", 0.2))
    assert to_rc[-1] == (0.7, "rc", {"throttle": 0.2, "mode": "rc"})


def test_a_re_enable_rises_later_and_repeats_the_remote_stop_request() -> None:
    events = _events(Step(0.2, "remote_stop", True), Step(0.1, "re_enable"))
    assert events[-2:] == [
        (0.3, "hlc_control", {"remote_stop": True, "re_enable": False}),
        (round(0.3 + RE_ENABLE_RISE_S, 6), "hlc_control", {"remote_stop": True, "re_enable": True}),
    ]


def test_a_stall_is_measured_in_the_robot_s_watchdog_periods() -> None:
    slow = parse_config('backend = "sim"\n[timeouts]\nwatchdog_s = 0.4\n', "<slow>")
    scenario = compile_steps([Step(0.2, "stall", "long")], slow)
    assert scenario.events[-1].values == {"fault": "dac_stall", "count": 1, "stall_s": 0.6}
