"""How `bywire verify` draws its bridge campaigns: a share of a run's campaigns, chosen apart so
that every other campaign is drawn exactly as before, opening enabled and driving, and over every
action and value of the bridge's vocabulary."""

from __future__ import annotations

from bywire.config import default_sim_config
from bywire.model import ControlMode, Gear
from bywire.sim.verify.actions import BRIDGE_ACTIONS, BRIDGE_PRESETS, compile_steps
from bywire.sim.verify.campaign import VOCABULARY, Step
from bywire.sim.verify.draw import draw_campaign
from bywire.sim.verify.draw_bridge import (
    BRIDGE_WEIGHTS,
    SLOPE_GRADES,
    draw_any,
    draw_bridge_campaign,
    is_bridge_campaign,
)

INDICES = range(400)


def test_a_share_of_the_campaigns_are_bridge_campaigns_and_the_others_are_unchanged() -> None:
    bridge = [index for index in INDICES if is_bridge_campaign(0, index)]
    assert 0.1 < len(bridge) / len(INDICES) < 0.3
    for index in INDICES:
        drawn = draw_any(0, index)
        if index in bridge:
            assert drawn == draw_bridge_campaign(0, index)
            assert drawn[0].action == "bridge"
        else:  # as `bywire verify` drew it before, maybe on a slope from the start
            unsloped = drawn[1:] if drawn[0].action == "grade" else drawn
            assert unsloped == draw_campaign(0, index)


def test_a_share_of_the_other_campaigns_open_downhill_at_every_grade() -> None:
    grades = [
        steps[0].value
        for steps in (draw_any(0, index) for index in INDICES)
        if steps[0].action == "grade"
    ]
    assert 0.1 < len(grades) / len(INDICES) < 0.4
    assert set(grades) == set(SLOPE_GRADES)
    assert all(value in VOCABULARY["grade"] for value in grades)
    assert draw_any(0, 5) == draw_any(0, 5)


def test_a_bridge_campaign_opens_enabled_with_the_planner_publishing() -> None:
    steps = draw_bridge_campaign(3, 7)
    assert steps == draw_bridge_campaign(3, 7)
    assert steps != draw_bridge_campaign(3, 8)
    assert [step.action for step in steps[:5]] == [
        "bridge",
        "arm",
        "bridge_enable",
        "planner_speed",
        "planner_link",
    ]
    assert steps[1].value is ControlMode.CAN
    assert steps[4].value is True
    assert 9.0 < sum(step.delay_s for step in steps) <= 9.5


def test_bridge_campaigns_draw_every_bridge_action_and_value() -> None:
    drawn = [step for index in range(200) for step in draw_bridge_campaign(0, index)]
    assert {step.action for step in drawn} == set(BRIDGE_WEIGHTS) | {"bridge"}
    assert {step.action for step in drawn} >= BRIDGE_ACTIONS
    for action in BRIDGE_ACTIONS:
        seen = {step.value for step in drawn if step.action == action}
        assert seen == set(VOCABULARY[action]), action


def test_a_bridge_campaign_compiles_to_a_scenario_run_by_the_bridge_with_its_parameters() -> None:
    robot = default_sim_config()
    for preset, parameters in BRIDGE_PRESETS.items():
        steps = [step for step in draw_bridge_campaign(0, 1) if step.action != "bridge"]
        scenario = compile_steps([Step(0.0, "bridge", preset), *steps], robot)
        assert scenario.computer == "bridge"
        assert dict(scenario.bridge) == parameters
    other = compile_steps(draw_campaign(0, 1), robot)
    assert (other.computer, other.bridge) == ("hlc", ())
    assert not any(event.kind in {"planner", "bridge_service"} for event in other.events)


def test_a_campaign_whose_two_mechanical_brakes_fail_stays_on_the_flat() -> None:
    both = [
        index
        for index in INDICES
        if not is_bridge_campaign(0, index)
        and {("ebrake", False), ("hydrobrake", False)}
        <= {(step.action, step.value) for step in draw_campaign(0, index)}
    ]
    assert both
    assert all(draw_any(0, index)[0].action != "grade" for index in both)


def test_a_campaign_that_selects_reverse_stays_on_the_flat() -> None:
    reversing = [
        index
        for index in INDICES
        if not is_bridge_campaign(0, index)
        and any(
            step.action in ("rc_gear", "can_gear") and step.value is Gear.REVERSE
            for step in draw_campaign(0, index)
        )
    ]
    assert reversing
    assert all(draw_any(0, index)[0].action != "grade" for index in reversing)
