"""How `bywire verify` draws its campaigns: the same for a seed and index, over the whole
vocabulary, and with the episodes an operator makes on purpose (a fault that ends, a re-arming
after it, a request that needs what just broke, a brake, a reversal or a stop in motion)."""

from __future__ import annotations

from itertools import pairwise

from bywire.model import ControlMode, Gear
from bywire.sim.verify.actions import BRIDGE_ACTIONS
from bywire.sim.verify.campaign import VOCABULARY, Step
from bywire.sim.verify.draw import (
    BRAKE_ON_THROTTLE,
    BRAKES_FAIL_ROLLING,
    DEMANDS,
    ENDINGS,
    IN_MOTION,
    RE_ENABLE,
    REVERSE_ROLLING,
    ROLLING_THROTTLE,
    SECOND_SENDER_ROLLING,
    SENSOR_DIES_ROLLING,
    after_impostor,
    draw_campaign,
    follow_ups,
    switch_after,
)

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP
CAMPAIGNS = [draw_campaign(0, index) for index in range(300)]


def test_a_campaign_is_drawn_the_same_for_its_seed_and_index() -> None:
    assert draw_campaign(3, 7) == draw_campaign(3, 7)
    assert draw_campaign(3, 7) != draw_campaign(3, 8)
    assert draw_campaign(3, 7) != draw_campaign(4, 7)


def test_campaigns_last_their_length_and_start_armed_and_driving() -> None:
    steps = draw_campaign(0, 0, campaign_s=10.0)
    assert steps[0].action == "arm"
    assert steps[1].action in {"rc_throttle", "can_throttle"}
    assert 9.0 < sum(step.delay_s for step in steps) <= 9.5


def _opened(steps: list[Step]) -> list[Step]:
    """The steps after the opening (authentication, the arming, the first throttle)."""
    return [step for step in steps if step.action != "secoc"][2:]


def test_campaigns_draw_every_action_and_value_of_the_vocabulary() -> None:
    """Every action but the bridge campaigns' own (`test_draw_bridge.py` holds those)."""
    drawn = [step for steps in CAMPAIGNS for step in _opened(steps)]
    opening_only = {"secoc", "grade"}  # drawn apart at the start (grade: `draw_any`)
    assert {step.action for step in drawn} == set(VOCABULARY) - opening_only - BRIDGE_ACTIONS
    assert any(steps[0].action == "secoc" for steps in CAMPAIGNS)  # some open authenticated
    for action, values in VOCABULARY.items():
        if action in opening_only or action in BRIDGE_ACTIONS:
            continue
        seen = {step.value for step in drawn if step.action == action}
        assert seen <= set(values)
        if not isinstance(values, range):
            assert seen == set(values), action


def test_the_switch_is_followed_through_arming_switching_and_handovers() -> None:
    assert switch_after(RC, Step(0.1, "arm", CAN)) is CAN
    assert switch_after(CAN, Step(0.1, "switch", STOP)) is STOP
    assert switch_after(RC, Step(0.1, "handover", 0.2)) is CAN
    assert switch_after(CAN, Step(0.1, "handover", 0.2)) is RC
    assert switch_after(STOP, Step(0.1, "handover", 0.2)) is RC  # the compiler goes to RC
    assert switch_after(CAN, Step(0.1, "flick", 0.05)) is CAN  # through STOP and back
    assert switch_after(CAN, Step(0.1, "rc_link", False)) is CAN


def test_a_fault_may_end_and_its_end_may_be_followed_by_a_re_arming_by_the_right_source() -> None:
    assert follow_ups(CAN, Step(0.1, "rc_link", False)) == [(ENDINGS[("rc_link", False)],)]
    at_can = follow_ups(CAN, Step(0.1, "rc_link", True))
    assert RE_ENABLE in at_can
    assert (Step(0.0, "arm", CAN),) in at_can
    assert follow_ups(RC, Step(0.1, "rc_link", True)) == [(Step(0.0, "arm", RC),)]
    assert follow_ups(STOP, Step(0.1, "rc_link", True)) == []  # at STOP: the operator's move
    assert follow_ups(RC, Step(0.1, "rc_throttle", 0.3)) == []


def test_in_motion_the_source_in_command_may_brake_reverse_or_stop() -> None:
    assert follow_ups(CAN, Step(0.1, "can_throttle", 0.6)) == [
        BRAKE_ON_THROTTLE,
        REVERSE_ROLLING[CAN],
        *SENSOR_DIES_ROLLING[CAN],
        SECOND_SENDER_ROLLING,
        BRAKES_FAIL_ROLLING[CAN],
    ]
    assert follow_ups(RC, Step(0.1, "rc_throttle", 0.8)) == [
        REVERSE_ROLLING[RC],
        *SENSOR_DIES_ROLLING[RC],
        BRAKES_FAIL_ROLLING[RC],
    ]
    assert follow_ups(RC, Step(0.1, "rc_steer", 0.5)) == [(Step(0.0, "switch", STOP),)]
    assert follow_ups(CAN, Step(0.1, "can_steer", -0.5)) == [(Step(0.0, "remote_stop", True),)]
    assert follow_ups(RC, Step(0.1, "can_throttle", 0.6)) == []  # CAN is not in command


def test_a_reversal_waits_for_speed_first() -> None:
    # The episode's own first delay is the least wait: the robot has had a second of throttle.
    let_go = [
        b.delay_s
        for steps in CAMPAIGNS
        for a, b, c in zip(steps, steps[1:], steps[2:], strict=False)
        if (a.action, a.value) == ("rc_throttle", 0.8)
        and (b.action, b.value) == ("rc_throttle", 0.0)
        and (c.action, c.value, c.delay_s) == ("rc_gear", Gear.REVERSE, 0.6)  # the episode's
    ]
    assert len(let_go) >= 5
    assert min(let_go) >= 1.0


def test_a_broken_actuator_meets_a_request_from_the_source_in_command() -> None:
    assert follow_ups(CAN, Step(0.1, "hydrobrake", False))[0] == DEMANDS[("hydrobrake", False)][CAN]
    servo = follow_ups(RC, Step(0.1, "servo", False))[0]
    assert servo[0] == Step(0.0, "rc_steer", 0.5)
    assert [(step.action, step.value) for step in servo[1:]] == [("servo", True), ("arm", RC)]


def test_the_wheel_sensor_dies_while_rolling_then_a_reversal_with_or_without_a_re_arming() -> None:
    for mode in (RC, CAN):
        dies, re_armed = SENSOR_DIES_ROLLING[mode]
        for episode in (dies, re_armed):
            assert episode[0] == Step(1.0, "wheel_sensor", False)  # a second of throttle first
            assert episode[-2:] == REVERSE_ROLLING[mode][-2:]
        assert re_armed[1] == Step(0.05, "arm", mode)


def test_after_a_second_sender_the_computer_asks_to_re_enable_once_it_is_over() -> None:
    episodes = follow_ups(CAN, Step(0.1, "impostor", 20))
    assert after_impostor(20) in episodes
    first, re_enable = after_impostor(20)
    assert first == Step(0.45, "can_throttle", 0.0)  # its 20 frames last 0.4 s
    assert re_enable.action == "re_enable"
    assert after_impostor(20) not in follow_ups(RC, Step(0.1, "impostor", 20))  # RC drives on
    # In motion, the request comes after the id is trusted again: 16 good frames, 0.32 s.
    assert SECOND_SENDER_ROLLING[1].delay_s >= 20 * 0.020 + 16 * 0.020


def _opens_rolling(steps: list[Step]) -> bool:
    steps = [step for step in steps if step.action != "secoc"]
    mode = switch_after(STOP, steps[0])
    source = "rc_throttle" if mode is RC else "can_throttle"
    episodes = IN_MOTION[(source, ROLLING_THROTTLE[mode])][mode]
    firsts = {(episode[0].action, episode[0].value) for episode in episodes}
    rolling = steps[1] == Step(0.15, source, ROLLING_THROTTLE[mode])
    return rolling and (steps[2].action, steps[2].value) in firsts


def test_a_quarter_of_the_campaigns_open_rolling_with_an_in_motion_episode() -> None:
    opening = sum(_opens_rolling(steps) for steps in CAMPAIGNS)
    assert 0.15 * len(CAMPAIGNS) <= opening <= 0.35 * len(CAMPAIGNS)


def _pairs(first: tuple[str, object], then: tuple[str, object]) -> int:
    """Campaigns in which `then` comes straight after `first`."""
    return sum(
        any(
            (a.action, a.value) == first and (b.action, b.value) == then for a, b in pairwise(steps)
        )
        for steps in CAMPAIGNS
    )


def test_campaigns_string_faults_endings_and_re_enables_together() -> None:
    # Drawn independently, an ending would follow its own fault straight away in about one
    # campaign of a hundred (a weight of 1 in about 60 for each step).
    assert _pairs(("rc_link", False), ("rc_link", True)) >= 20
    assert _pairs(("dac", "fail"), ("dac", "restore")) >= 10
    assert _pairs(("can_throttle", 0.0), ("re_enable", None)) >= 30
    assert _pairs(("can_throttle", 0.6), ("can_brake", 1.0)) >= 10
