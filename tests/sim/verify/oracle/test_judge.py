"""The hazard oracle leans towards allowing where the controller's timing is uncertain, and still
flags what the hardware must never show.

The two replays are failures `bywire verify --seed 4` reported against a correct controller: the
oracle was too strict. Each is paired with a check on the oracle alone that the same rule still
flags the hazard once the uncertainty is over.
"""

from __future__ import annotations

import textwrap
from dataclasses import replace

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode
from bywire.protocol import dac6574
from bywire.sim.scenario import parse_scenario
from bywire.sim.verify.campaign import Campaign, CampaignResult, Step
from bywire.sim.verify.draw import draw_campaign
from bywire.sim.verify.engine import run_campaign
from bywire.sim.verify.oracle import HazardOracle, Invariant, OracleCause, OracleTiming
from bywire.sim.verify.oracle.outputs import Outputs

RC, CAN = ControlMode.RC, ControlMode.CAN
H1, H2, H4, H6 = Invariant.H1, Invariant.H2, Invariant.H4, Invariant.H6

ARMED_IN_CAN = """
    { at_s = 0.0, rc = { gear = "forward" } },
    { at_s = 0.0, hlc = { steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" } },
    { at_s = 0.2, rc = { mode = "stop" } },
    { at_s = 0.26, hlc = { throttle = 0.0 } },
    { at_s = 0.26, rc = { mode = "can" } },
"""


def _violations(events: str, duration_s: float) -> list[str]:
    text = f'name = "case"\nduration_s = {duration_s}\nevent = [{ARMED_IN_CAN}{events}]\n'
    result = Campaign().run_scenario(parse_scenario(text, "<test>"))
    assert result.oracle.checks > 0
    return [f"{v.invariant} at {v.time_s:.4f}: {v.detail}" for v in result.oracle.violations]


def _oracle(robot: RobotConfig | None = None, *, boosted: bool = False) -> HazardOracle:
    robot = robot or default_sim_config()
    world = SimWorld.from_robot(VirtualClock(), robot)
    timing = OracleTiming.for_robot(robot)
    timing = replace(timing, steering_boosted=True) if boosted else timing
    return HazardOracle(world, timing=timing)


def _only(oracle: HazardOracle, invariant: Invariant, now: float, **shown: object) -> None:
    """Judge the hardware as the world shows it at `now`, but with the levels `shown`, and keep
    what `invariant` alone found (one invariant's check in isolation)."""
    seen = Outputs.read(oracle.world)
    before = len(oracle.violations)
    oracle.judge(replace(seen, **shown), now)  # type: ignore[arg-type]
    found = oracle.violations[before:]
    oracle.violations[before:] = [v for v in found if v.invariant is invariant]


# --- H2: the switch's move travels in IBUS frames that corruption may delay ---------------------


def test_a_move_to_rc_hidden_by_corrupted_frames_is_not_judged_before_they_end() -> None:
    # verify seed 4, campaign 106: CAN drives at 0.2; the switch goes to RC with the stick at
    # 0.2 and the next ten frames are corrupted. The controller, rightly, is still in CAN.
    events = """
        { at_s = 0.3, hlc = { throttle = 0.2 } },
        { at_s = 1.5, rc = { throttle = 0.2, mode = "rc" } },
        { at_s = 1.51, fault = "ibus_corrupt", count = 10 },
    """
    assert _violations(events, 2.05) == []


def test_h2_still_flags_rc_never_at_zero_once_the_corrupted_frames_are_over() -> None:
    oracle = _oracle()
    oracle.set_throttle(RC, 0.2, 1.0)
    oracle.set_switch(RC, 1.5)
    oracle.blind(RC, 1.51, 1.6)
    _h2_flags_from(oracle, 1.6 + oracle.timing.settle_s)


def _h2_flags_from(oracle: HazardOracle, settled_s: float) -> None:
    """Driving on a source never seen at zero is allowed until `settled_s`, H2 after it."""
    _only(oracle, H2, settled_s - 0.001, enable=True, throttle_volts=1.0)
    assert oracle.violations == []
    _only(oracle, H2, settled_s + 0.001, enable=True, throttle_volts=1.0)
    assert [v.invariant for v in oracle.violations] == ["H2"]


# --- H1: a handover to RC before the controller acts on a CAN-bound fault -----------------------


def test_a_handover_to_rc_before_a_second_sender_is_noticed_lets_rc_drive() -> None:
    # verify seed 4, campaign 227: armed in CAN, a second node sends on the computer's id, and
    # 47 ms later the switch goes straight to RC with the stick at zero. The controller hands
    # over before it distrusts the id; CAN-bound causes never block RC.
    events = """
        { at_s = 1.652, fault = "can_impostor", count = 5 },
        { at_s = 1.699, rc = { throttle = 0.0, mode = "rc" } },
    """
    assert _violations(events, 2.36) == []


def _armed_in_can(oracle: HazardOracle) -> None:
    oracle.set_switch(CAN, 0.0)
    oracle.re_enable(0.0)
    assert oracle.ledger.armed


def test_h1_still_flags_rc_driving_after_a_can_stop_the_controller_must_have_taken() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.CAN_IMPOSTOR, True, 1.0)
    deadline_s = oracle.ledger.deadline_s
    assert deadline_s is not None
    oracle.set_switch(RC, deadline_s + 0.001)  # too late: the controller had stopped by then
    _only(oracle, H1, deadline_s + 0.1, enable=True, released=True, throttle_volts=0.0)
    assert [v.invariant for v in oracle.violations] == ["H1"]


def test_h1_still_flags_a_handover_that_an_rc_bound_stop_forbids() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.CAN_IMPOSTOR, True, 1.0)
    oracle.fault(OracleCause.DAC_FAIL, True, 1.01)  # stops every source, not only CAN
    oracle.set_switch(RC, 1.02)
    _only(oracle, H1, 1.5, enable=True, released=True, throttle_volts=0.0)
    assert [v.invariant for v in oracle.violations] == ["H1"]


# --- H1/H2: a trip through STOP that no frame showed --------------------------------------------


def test_a_trip_through_stop_inside_corrupted_frames_leaves_the_robot_driving() -> None:
    # verify seed 7 (config/albert.toml), campaign 200: CAN drives at 0.2; ten IBUS frames are
    # corrupted, and within them the switch goes to STOP and back to CAN 20 ms later. No frame
    # showed STOP: the controller rightly drives on.
    events = """
        { at_s = 0.3, hlc = { throttle = 0.2 } },
        { at_s = 1.0, fault = "ibus_corrupt", count = 10 },
        { at_s = 1.03, rc = { mode = "stop" } },
        { at_s = 1.05, rc = { mode = "can" } },
    """
    assert _violations(events, 1.63) == []


def _driving_after_a_stop(back_s: float) -> list[str]:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.set_throttle(CAN, 0.2, 0.5)
    oracle.blind(RC, 1.0, 1.077)
    oracle.set_switch(ControlMode.STOP, 1.03)
    oracle.set_switch(CAN, back_s)
    oracle.arming.resolve(1.5)  # the debounce is over: back at CAN with the throttle pushed
    _only(oracle, H1, 1.5, enable=True, released=True, throttle_volts=1.0)
    return [v.invariant for v in oracle.violations]


def test_h1_still_flags_driving_on_after_a_stop_the_frames_showed() -> None:
    assert _driving_after_a_stop(1.05) == []  # hidden by the corruption
    assert _driving_after_a_stop(1.2) == ["H1"]  # held past it: the controller saw STOP


# --- H2: back to the driving source after glimpses of other positions -----------------------------


def test_glimpses_of_stop_and_can_between_rc_and_rc_leave_rc_driving() -> None:
    # verify seed 8, campaign 86: armed in RC; the switch goes to STOP for 5 ms, to CAN for
    # 5 ms and back to RC with the stick at 0.2. No frame may have shown STOP, and CAN for less
    # than the debounce's frames: the controller may never have left RC, and rightly drives.
    text = """
        name = "case"
        duration_s = 6.68
        event = [
            { at_s = 0.0, rc = { gear = "forward" } },
            { at_s = 5.837, rc = { mode = "stop" } },
            { at_s = 5.897, rc = { throttle = 0.0, mode = "rc" } },
            { at_s = 6.116, rc = { mode = "stop" } },
            { at_s = 6.121, rc = { mode = "can" } },
            { at_s = 6.126, rc = { throttle = 0.2, mode = "rc" } },
        ]
    """
    result = Campaign().run_scenario(parse_scenario(textwrap.dedent(text), "<test>"))
    assert result.oracle.checks > 0
    assert result.oracle.violations == []


def test_h2_still_flags_a_handover_to_rc_after_can_had_settled() -> None:
    oracle = _oracle()
    oracle.set_switch(RC, 0.0)
    oracle.set_switch(ControlMode.STOP, 1.116)
    oracle.set_switch(CAN, 1.121)
    oracle.set_throttle(RC, 0.2, 1.5)
    oracle.set_switch(RC, 1.5)  # CAN held long past the debounce: a real handover
    _only(oracle, H2, 1.5 + oracle.timing.settle_s + 0.001, enable=True, throttle_volts=1.0)
    assert [v.invariant for v in oracle.violations] == ["H2"]


def test_a_handover_the_lost_link_never_showed_leaves_rc_driving_until_its_timeout() -> None:
    # verify seed 0, campaign 549: RC drives at 0.3, the switch moves to CAN (asking 0.2) and
    # the link dies 15 ms later, before the debounce's frames: the controller rightly stays RC.
    steps = [
        Step(6.6, "arm", RC),
        Step(0.6, "rc_throttle", 0.3),
        Step(0.44, "handover", 0.2),
        Step(0.06, "rc_link", False),
    ]
    outcome = run_campaign(default_sim_config(), steps)
    assert outcome.checks > 0
    assert outcome.findings == []


def _moved_to_can_at_speed() -> HazardOracle:
    oracle = _oracle()
    oracle.set_throttle(CAN, 0.2, 0.9)
    oracle.set_switch(CAN, 1.0)
    return oracle


def test_h2_judges_a_move_the_lost_link_hid_once_the_link_is_back() -> None:
    oracle = _moved_to_can_at_speed()
    oracle.fault(OracleCause.RC_LINK_LOST, True, 1.01)
    _only(oracle, H2, 1.3, enable=True, throttle_volts=1.0)
    oracle.fault(OracleCause.RC_LINK_LOST, False, 1.5)
    _h2_flags_from(oracle, 1.5 + oracle.timing.settle_s)


def test_h2_judges_a_move_the_frames_showed_before_the_link_was_lost() -> None:
    oracle = _moved_to_can_at_speed()
    oracle.fault(OracleCause.RC_LINK_LOST, True, 1.0 + oracle.timing.settle_s + 0.001)
    _only(oracle, H2, 1.0 + oracle.timing.settle_s + 0.002, enable=True, throttle_volts=1.0)
    assert [v.invariant for v in oracle.violations] == ["H2"]


# --- H1: a CAN re-enable re-arms only what CAN may clear (S8) -----------------------------------


def _stopped_by(kind: OracleCause, began_s: float, ended_s: float) -> HazardOracle:
    """Armed in CAN, then `kind` from `began_s` to `ended_s`, the switch left at CAN."""
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(kind, True, began_s)
    oracle.fault(kind, False, ended_s)
    return oracle


def _drives_after_re_enable(oracle: HazardOracle, at_s: float) -> list[str]:
    oracle.re_enable(at_s)
    _only(oracle, H1, at_s + 0.2, enable=True, released=True, throttle_volts=0.0)
    return [v.invariant for v in oracle.violations]


def test_a_re_enable_after_a_lost_rc_link_is_no_arming_act() -> None:
    oracle = _stopped_by(
        OracleCause.RC_LINK_LOST, 1.0, 1.5
    )  # RC_LOST latched: only the switch clears it
    assert _drives_after_re_enable(oracle, 2.0) == ["H1"]


def test_a_re_enable_after_a_lost_can_link_arms() -> None:
    oracle = _stopped_by(OracleCause.CAN_LOST, 1.0, 1.5)  # CAN_LOST: what a re-enable is for
    assert _drives_after_re_enable(oracle, 2.0) == []


def test_an_rc_link_lost_shorter_than_its_deadline_may_never_have_latched() -> None:
    deadline_s = _oracle().timing.deadline_s(OracleCause.RC_LINK_LOST)
    oracle = _stopped_by(OracleCause.RC_LINK_LOST, 1.0, 1.0 + deadline_s - 0.001)
    assert _drives_after_re_enable(oracle, 2.0) == []


def test_failing_dac_writes_still_in_force_refuse_a_re_enable_once_surely_latched() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.DAC_FAIL, True, 1.0)
    assert oracle.ledger.owed_now(1.1) == set()  # not yet for sure: a re-enable may still arm
    assert oracle.ledger.owed_now(1.3) == {OracleCause.DAC_FAIL}


def test_after_a_visit_to_stop_a_re_enable_arms_again() -> None:
    oracle = _stopped_by(OracleCause.RC_LINK_LOST, 1.0, 1.5)
    oracle.set_switch(ControlMode.STOP, 1.6)
    oracle.set_switch(CAN, 1.7)  # the switch's own arming may be refused (throttle): then…
    oracle.ledger.armed = False
    assert _drives_after_re_enable(oracle, 2.0) == []  # …the computer's re-enable arms


def test_a_watchdog_trip_is_owed_to_the_switch_unless_it_came_at_stop() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.stall(1.0, 1.25)
    assert oracle.ledger.owed_now(1.2) == set()
    assert oracle.ledger.owed_now(1.3) == {OracleCause.WATCHDOG}
    at_stop = _oracle()
    at_stop.set_switch(ControlMode.STOP, 0.5)
    at_stop.stall(1.0, 1.25)
    assert at_stop.ledger.owed_now(1.3) == set()


def test_implausible_frames_that_corruption_may_have_hidden_refuse_no_re_enable() -> None:
    seen = _oracle()
    _armed_in_can(seen)
    seen.stop_event(OracleCause.RC_IMPLAUSIBLE, 1.0)
    assert seen.ledger.owed_now(1.1) == {OracleCause.RC_IMPLAUSIBLE}
    hidden = _oracle()
    _armed_in_can(hidden)
    hidden.stop_event(OracleCause.RC_IMPLAUSIBLE, 1.0)
    hidden.blind(RC, 1.005, 1.05)  # the frames were still to be sent
    assert hidden.ledger.owed_now(1.1) == set()


def test_failsafe_frames_sent_while_the_link_was_lost_are_not_held_against_a_re_enable() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.RC_LINK_LOST, True, 1.0)
    oracle.fault(OracleCause.RC_FAILSAFE, True, 1.01)
    assert OracleCause.RC_FAILSAFE not in oracle.ledger.owed_now(1.5)
    assert OracleCause.RC_LINK_LOST in oracle.ledger.owed_now(1.5)


# --- H5: STOP brakes with the hydraulic brake and holds the steering ---------------------------


def _in_stop(
    steering_pulse_s: float = 0.0015, duty: float = 1.0, *, boosted: bool = False
) -> HazardOracle:
    """At power-up (the drive must be cut), the brake and the steering as given."""
    oracle = _oracle(boosted=boosted)
    pwm = oracle.world.pwm
    pwm.hydrobrake.set_pulse(duty * pwm.hydrobrake.period_s)
    pwm.steering.set_pulse(steering_pulse_s)
    return oracle


def test_h5_flags_a_stop_without_the_hydraulic_brake_at_full_duty() -> None:
    oracle = _in_stop(duty=0.5)
    oracle.observe(0.01)
    assert [(v.invariant, v.expected) for v in oracle.violations] == [
        ("H5", {"hydrobrake_duty_min": 1.0})
    ]


def test_h5_flags_a_steering_pulse_that_moves_in_stop_and_names_where_it_was_held() -> None:
    oracle = _in_stop(steering_pulse_s=0.0017)
    oracle.observe(0.01)
    assert oracle.violations == []
    oracle.world.pwm.steering.set_pulse(0.0016)
    oracle.observe(0.02)
    assert [v.invariant for v in oracle.violations] == ["H5"]
    assert oracle.violations[0].expected["steering_held_since_s"] == 0.01


def test_h5_holds_the_steering_from_when_the_drive_must_be_cut_not_from_the_stop() -> None:
    # Armed, the steering turns; a remote stop: until its deadline the controller may still
    # steer, then the pulse must stay where it was at the deadline.
    oracle = _in_stop()
    oracle.arming.arm_now(1.0, CAN)
    oracle.world.pwm.steering.set_pulse(0.0017)
    oracle.observe(1.5)
    oracle.stop_event(OracleCause.REMOTE_STOP, 2.0)
    oracle.world.pwm.steering.set_pulse(0.0018)
    oracle.observe(2.01)  # before the deadline: the controller may not have acted yet
    oracle.observe(2.5)
    assert oracle.violations == []
    oracle.world.pwm.steering.set_pulse(0.0015)
    oracle.observe(2.6)
    assert [v.invariant for v in oracle.violations] == ["H5"]


def test_driving_on_in_stop_is_h1_alone_not_h5_as_well() -> None:
    oracle = _in_stop(duty=0.0)
    oracle.world.gpio["motors_enable"].set(True)
    oracle.world.gpio["ebrake_release"].set(True)
    oracle.observe(0.01)
    assert [v.invariant for v in oracle.violations] == ["H1"]


def test_a_stop_with_the_e_brake_engaged_is_judged_by_h5_even_with_the_drive_powered() -> None:
    # A controlled stop (category 1) keeps the enable line high: its hydraulic brake is judged.
    oracle = _in_stop(duty=0.0)
    oracle.world.gpio["motors_enable"].set(True)
    oracle.observe(0.01)
    assert "H5" in {v.invariant for v in oracle.violations}


# --- a write that hangs the loop, short of a watchdog trip ---------------------------------------


def test_a_stop_that_comes_while_a_write_hangs_is_judged_after_the_loop_runs_again() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.hang(1.0, 1.06)
    oracle.stop_event(OracleCause.REMOTE_STOP, 1.01)
    after_s = 1.06 + 2 * oracle.timing.control_period_s
    assert 1.01 + oracle.timing.deadline_s(OracleCause.REMOTE_STOP) < after_s
    _only(oracle, H1, after_s - 0.001, enable=True, released=True, throttle_volts=0.0)
    assert oracle.violations == []
    _only(oracle, H1, after_s + 0.001, enable=True, released=True, throttle_volts=0.0)
    assert [v.invariant for v in oracle.violations] == ["H1"]


def test_a_stop_whose_deadline_had_passed_before_the_hang_is_not_extended() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.stop_event(OracleCause.REMOTE_STOP, 1.0)
    oracle.hang(1.2, 1.25)
    _only(oracle, H1, 1.21, enable=True, released=True, throttle_volts=0.0)
    assert [v.invariant for v in oracle.violations] == ["H1"]


# --- H6: the brake beats the throttle ------------------------------------------------------------


def _driving_with(oracle: HazardOracle, throttle_code: int, duty: float) -> None:
    world = oracle.world
    world.dac.write(
        dac6574.encode_write(oracle.world.vehicle.wiring.throttle_channel, throttle_code)
    )
    world.pwm.hydrobrake.set_pulse(duty * world.pwm.hydrobrake.period_s)
    world.gpio["motors_enable"].set(True)
    world.gpio["ebrake_release"].set(True)


def _h6_after(oracle: HazardOracle, *times_s: float) -> list[str]:
    for now in times_s:
        _only(oracle, H6, now, enable=True)
    return [v.invariant for v in oracle.violations]


def test_h6_flags_throttle_with_the_brake_for_longer_than_a_control_period() -> None:
    oracle = _oracle()
    _driving_with(oracle, 128, 1.0)
    period_s = oracle.timing.control_period_s
    assert _h6_after(oracle, 1.0, 1.0 + period_s) == []  # one task a pass ahead of the other
    assert _h6_after(oracle, 1.0 + period_s + 0.002) == ["H6"]


def test_h6_leaves_a_dac_whose_writes_fail_to_the_enable_line() -> None:
    oracle = _oracle()
    _driving_with(oracle, 128, 1.0)
    oracle.fault(OracleCause.DAC_FAIL, True, 0.5)
    assert _h6_after(oracle, 1.0, 1.1, 1.2) == []
    assert _h6_after(oracle, 1.0, 1.1, 1.2) == []


def test_h6_leaves_throttle_without_a_brake_alone() -> None:
    oracle = _oracle()
    _driving_with(oracle, 128, 0.0)
    assert _h6_after(oracle, 1.0, 1.1, 1.2) == []


# --- a robot file with other numbers -------------------------------------------------------------


def test_with_a_boosted_steering_the_pulse_may_settle_in_stop_but_the_brake_is_judged() -> None:
    # A boosted pulse overshoots the set-point while the servo catches up, then settles onto
    # it: in STOP the set-point is held, and the pulse still moves.
    robot = default_sim_config()
    boosted = replace(
        robot, steering=replace(robot.steering, servo=replace(robot.steering.servo, boost_gain=1.0))
    )
    steps = [
        Step(0.2, "arm", RC),
        Step(0.15, "rc_steer", 0.5),
        Step(0.08, "switch", ControlMode.STOP),
    ]
    outcome = run_campaign(boosted, steps)
    assert outcome.checks > 0
    assert outcome.findings == []
    oracle = _in_stop(steering_pulse_s=0.0017, duty=0.5, boosted=True)
    oracle.observe(0.01)
    oracle.world.pwm.steering.set_pulse(0.0016)
    oracle.observe(0.02)
    assert [v.detail for v in oracle.violations] == ["in STOP: hydraulic brake at 0.50 duty"] * 2


def test_a_brake_task_faster_than_the_driving_task_may_brake_a_pass_before_the_drive_is_cut() -> (
    None
):
    # CAN goes silent while driving: the 200 Hz brake task applies STOP's full duty a pass
    # before the 100 Hz driving task cuts the enable line and the throttle.
    robot = default_sim_config()
    rates = tuple(
        (name, 200.0 if name == "hydrobrake" else hz) for name, hz in robot.tasks.rates_hz
    )
    faster = replace(robot, tasks=replace(robot.tasks, rates_hz=rates))
    steps = [Step(0.2, "arm", CAN), Step(0.15, "can_throttle", 0.6), Step(1.53, "can_link", False)]
    outcome = run_campaign(faster, steps)
    assert outcome.checks > 0
    assert outcome.findings == []


def test_a_hang_long_after_the_switch_settled_does_not_pause_h2() -> None:
    oracle = _moved_to_can_at_speed()  # CAN never seen at zero since the move at 1.0
    oracle.hang(2.0, 2.06)
    _only(oracle, H2, 2.05, enable=True, throttle_volts=1.0)
    assert [v.invariant for v in oracle.violations] == ["H2"]


def test_with_slower_control_tasks_failing_dac_writes_get_a_longer_deadline() -> None:
    # At 50 Hz the three failed writes that stop the robot take 60 ms, not 30 ms.
    robot = default_sim_config()
    rates = tuple(
        (name, 50.0 if name in ("steering", "driving", "hydrobrake") else hz)
        for name, hz in robot.tasks.rates_hz
    )
    slower = replace(robot, tasks=replace(robot.tasks, rates_hz=rates))
    timing = OracleTiming.for_robot(slower)
    at_100_hz_s = OracleTiming().deadline_s(OracleCause.DAC_FAIL)
    assert timing.deadline_s(OracleCause.DAC_FAIL) == pytest.approx(2 * at_100_hz_s)
    # verify --config (50 Hz) seed 0, campaign 1, shrunk: H1 at the old 60 ms deadline.
    outcome = run_campaign(slower, [Step(3.1, "arm", RC), Step(3.1, "dac", "alternate")])
    assert outcome.checks > 0
    assert outcome.findings == []


def test_a_glimpse_away_from_stop_that_no_frame_showed_does_not_end_the_hold() -> None:
    # verify --config (debounce 5, frames every 14 ms), seed 0, campaign 19: STOP held 60 ms,
    # RC for no time at all, STOP 20 ms more, then RC. The controller saw one hold of 80 ms
    # (five frames) and armed, rightly; the oracle counted 20 ms.
    robot = default_sim_config()
    robot = replace(
        robot,
        sim=replace(robot.sim, rc_frame_period_s=0.014),
        supervisor=replace(robot.supervisor, debounce_frames=5),
    )
    outcome = run_campaign(robot, [Step(6.6, "arm", RC), Step(0.06, "flick", 0.02)])
    assert outcome.checks > 0
    assert "STOP->RC: armed by the switch" in outcome.transitions
    assert outcome.findings == []


def _on_other_numbers(
    events: str, duration_s: float, frame_s: float, debounce_frames: int = 3
) -> CampaignResult:
    """A found campaign replayed on the robot file it was found on (as far as it matters: the
    frame period and the debounce), armed in RC from power-up with the computer at rest."""
    robot = default_sim_config()
    robot = replace(
        robot,
        sim=replace(robot.sim, rc_frame_period_s=frame_s),
        supervisor=replace(robot.supervisor, debounce_frames=debounce_frames),
    )
    text = (
        f'name = "case"\nduration_s = {duration_s}\nevent = [\n'
        '{ at_s = 0.0, rc = { gear = "forward" } },\n'
        '{ at_s = 0.0, hlc = { steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" } },\n'
        f"{events}]\n"
    )
    result = Campaign(robot).run_scenario(parse_scenario(text, "<test>"))
    assert result.oracle.checks > 0
    return result


def test_two_glimpses_of_stop_that_no_frame_showed_leave_rc_driving() -> None:
    # verify --config (debounce 4, frames every 14.4 ms), seed 5, campaign 195: armed in RC, the
    # switch at STOP for 5 ms, RC for 15 ms, STOP for 5 ms, RC. Both frames around each glimpse
    # read RC, so the controller rightly drove on; the oracle joined the glimpses into one stay
    # at STOP of 25 ms (the RC between them counted as STOP time) and called it surely seen.
    events = """
        { at_s = 7.4, rc = { mode = "stop" } },
        { at_s = 7.46, rc = { throttle = 0.0, mode = "rc" } },
        { at_s = 7.618, rc = { mode = "stop" } },
        { at_s = 7.623, rc = { mode = "rc" } },
        { at_s = 7.638, rc = { mode = "stop" } },
        { at_s = 7.643, rc = { mode = "rc" } },
    """
    assert _on_other_numbers(events, 8.24, 0.0144, 4).oracle.violations == []


def test_a_bouncing_switch_s_last_frame_at_stop_may_begin_the_hold() -> None:
    # verify --config (debounce 6, frames every 12.7 ms), seed 10, campaign 26: the switch
    # bouncing (every other frame at STOP) is moved to STOP for 60 ms, less than the 63.5 ms six
    # frames span, then to RC. The bounce's frame just before the move read STOP too: six
    # frames in a row showed STOP and the controller rightly armed on the way back to RC.
    events = """
        { at_s = 5.908, rc = { throttle = 0.0, mode = "rc" } },
        { at_s = 6.708, fault = "switch_chatter", count = 23 },
        { at_s = 6.952, rc = { mode = "stop" } },
        { at_s = 7.012, rc = { throttle = 0.0, mode = "rc" } },
    """
    assert _on_other_numbers(events, 7.59, 0.0127, 6).oracle.violations == []


@pytest.mark.parametrize(
    ("implausible_s", "corrupt_s"), [(7.546, 7.536), (7.536, 7.538)], ids=["after", "before"]
)
def test_implausible_frames_that_corruption_may_take_whole_demand_no_stop(
    implausible_s: float, corrupt_s: float
) -> None:
    # verify --config (frames every 16.7 ms), seed 22, campaign 14: one frame corrupted from
    # 7.536 s, the next frame implausible from 7.546 s: it was the same frame, dropped for its
    # checksum, so the controller never saw the pulse and rightly drove on. The other order
    # too: the pulse asked for first, the corruption 2 ms later, before its frame went out.
    events = f"""
        {{ at_s = 1.626, rc = {{ mode = "stop" }} }},
        {{ at_s = 1.686, rc = {{ throttle = 0.0, mode = "rc" }} }},
        {{ at_s = {corrupt_s}, fault = "ibus_corrupt", count = 1 }},
        {{ at_s = {implausible_s}, fault = "rc_implausible", count = 1 }},
    """
    assert _on_other_numbers(events, 8.17, 0.0167).oracle.violations == []


def test_a_re_enable_sent_as_the_switch_leaves_can_may_arm_before_the_move_shows() -> None:
    # verify --config (debounce 5, frames every 16.8 ms), seed 34, campaign 81: stopped with the
    # switch at CAN; the operator moves it to RC and 5 ms later the computer sends a re-enable.
    # The controller's switch is still CAN (no frame showed RC yet): it arms into CAN, then
    # hands over to RC at zero throttle, rightly; the oracle only counted a re-enable at CAN.
    events = """
        { at_s = 0.683, rc = { mode = "stop" } },
        { at_s = 0.743, rc = { throttle = 0.0, mode = "rc" } },
        { at_s = 3.583, rc = { mode = "stop" } },
        { at_s = 3.643, rc = { throttle = 0.0, mode = "rc" } },
        { at_s = 4.218, rc = { mode = "can" } },
        { at_s = 5.453, rc = { throttle = 0.0, mode = "rc" } },
        { at_s = 5.458, hlc_control = { remote_stop = false, re_enable = true } },
    """
    result = _on_other_numbers(events, 5.96, 0.0168, 5)
    assert "STOP->CAN: armed by a CAN re-enable" in result.transitions
    assert result.oracle.violations == []


SLOW_DRIVING = 'backend = "sim"\n[tasks]\nsteering_rate_hz = 25\ndriving_rate_hz = 50\n'


def test_every_other_dac_write_failing_for_less_than_it_takes_to_latch_may_pass_unseen() -> None:
    # tests/sim/verify/test_other_numbers.py under the long profile (driving task at 50 Hz): every
    # other DAC write NAKed for 70 ms. The leaky count latches at the fourth failure, 80 ms at
    # 50 Hz; it never did and the robot rightly drove on, but the oracle gave the fault the
    # 60 ms that failing pairs of writes take.
    # (every task at 50 Hz or slower: a tighter speed check keeps the dead-sensor deadline)
    robot = parse_config(
        SLOW_DRIVING + "hydrobrake_rate_hz = 25\n[interlocks]\nspeed_step_tolerance_mps = 0.2\n",
        "<test>",
    )
    steps = [Step(0.2, "arm", RC), Step(0.61, "dac", "alternate"), Step(0.07, "dac", "restore")]
    outcome = run_campaign(robot, steps)
    assert outcome.checks > 0
    assert outcome.findings == []


@pytest.mark.parametrize(("every_other", "flagged"), [(False, ["H1"]), (True, [])])
def test_a_dac_failure_long_enough_to_latch_its_pattern_is_still_judged(
    every_other: bool, flagged: list[str]
) -> None:
    oracle = _oracle(parse_config(SLOW_DRIVING, "<test>"))  # driving period 20 ms
    oracle.set_switch(RC, 0.5)
    oracle.arming.resolve(0.7)
    oracle.dac_failing(1.0, every_other=every_other)
    oracle.fault(OracleCause.DAC_FAIL, False, 1.07)  # 3.5 periods: latched if every write failed
    _only(oracle, H1, 1.2, enable=True, released=True, throttle_volts=0.0)
    assert [violation.invariant for violation in oracle.violations] == flagged


def test_without_a_bouncing_switch_a_stop_too_short_for_the_debounce_still_refuses_arming() -> None:
    def driving_after_a_short_stop(bouncing: bool) -> list[str]:
        """Armed in RC; STOP for 13 ms (surely seen, short of the two frame periods a debounce
        of 3 needs), then RC, with the robot driving on."""
        oracle = _oracle()
        oracle.set_switch(RC, 0.5)
        oracle.arming.resolve(0.7)
        assert oracle.ledger.armed
        if bouncing:
            oracle.chatter(8, 0.95)
        oracle.set_switch(ControlMode.STOP, 1.0)
        oracle.set_switch(RC, 1.013)
        oracle.arming.resolve(1.5)
        _only(oracle, H1, 1.5, enable=True, released=True, throttle_volts=0.0)
        return [violation.invariant for violation in oracle.violations]

    assert driving_after_a_short_stop(bouncing=False) == ["H1"]
    assert driving_after_a_short_stop(bouncing=True) == []


def test_implausible_frames_that_outlast_the_corruption_still_demand_a_stop() -> None:
    oracle = _oracle()
    oracle.set_switch(RC, 0.5)
    oracle.arming.resolve(0.7)
    oracle.blind(RC, 1.0, 1.02)
    oracle.implausible(1, 1.005)  # its frame goes out by 1.0127: it may be lost
    assert oracle.ledger.armed
    oracle.implausible(3, 1.01)  # the last of its frames goes out after the corruption
    assert not oracle.ledger.armed
    _only(oracle, H1, 1.2, enable=True, released=True, throttle_volts=0.0)
    assert [violation.invariant for violation in oracle.violations] == ["H1"]


@pytest.mark.parametrize("then", ["corruption after the frames went out", "a stop meanwhile"])
def test_an_implausible_stop_stands_unless_the_corruption_may_have_taken_it(then: str) -> None:
    oracle = _oracle()  # frames every 7.7 ms
    oracle.set_switch(RC, 0.5)
    oracle.arming.resolve(0.7)
    oracle.implausible(1, 1.0)
    if then == "a stop meanwhile":
        oracle.fault(OracleCause.DAC_FAIL, True, 1.002)
        oracle.blind(RC, 1.003, 1.03)  # would have taken the frame, but the DAC stops it too
    else:
        oracle.blind(RC, 1.02, 1.05)  # the frame went out by 1.0077
    assert not oracle.ledger.armed
    _only(oracle, H1, 1.2, enable=True, released=True, throttle_volts=0.0)
    assert [violation.invariant for violation in oracle.violations] == ["H1"]


@pytest.mark.parametrize("moved_to", [ControlMode.STOP, RC], ids=["to STOP", "to RC"])
def test_a_re_enable_after_the_switch_left_can_for_good_arms_nothing(moved_to: ControlMode) -> None:
    oracle = _oracle()
    oracle.set_switch(CAN, 0.5)  # held at STOP since power-up: arms into CAN…
    oracle.arming.resolve(0.7)
    oracle.stop_event(OracleCause.REMOTE_STOP, 1.0)  # …then stopped
    oracle.set_switch(moved_to, 1.5)
    oracle.re_enable(1.502 if moved_to is ControlMode.STOP else 1.8)  # STOP: at once; RC: settled
    _only(oracle, H1, 2.0, enable=True, released=True, throttle_volts=0.0)
    assert [violation.invariant for violation in oracle.violations] == ["H1"]


# --- S8 against a second sender: CAN_UNTRUSTED is the switch's to clear -------------------------


def _second_sender(lasting_s: float, motors_enabled: bool = True) -> HazardOracle:
    """Armed in CAN, driving (the motors enabled, the e-brake released) or not, then a second
    sender from 1 s for `lasting_s`."""
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.world.gpio["motors_enable"].set(motors_enabled)
    oracle.world.gpio["ebrake_release"].set(motors_enabled)
    oracle.fault(OracleCause.CAN_IMPOSTOR, True, 1.0)
    oracle.fault(OracleCause.CAN_IMPOSTOR, False, 1.0 + lasting_s)
    return oracle


def test_a_second_sender_that_surely_latched_refuses_a_re_enable_after_it_is_over() -> None:
    deadline_s = _oracle().timing.deadline_s(OracleCause.CAN_IMPOSTOR)
    assert _drives_after_re_enable(_second_sender(deadline_s + 0.1), 2.0) == ["H1"]


def test_a_second_sender_too_short_to_latch_for_sure_leaves_a_re_enable_alone() -> None:
    deadline_s = _oracle().timing.deadline_s(OracleCause.CAN_IMPOSTOR)
    assert _drives_after_re_enable(_second_sender(deadline_s - 0.05), 2.0) == []


def test_a_second_sender_met_in_a_controlled_stop_may_never_have_latched() -> None:
    # verify seed 29, campaign 72: the robot braking with its drive powered (category 1, the
    # enable line high, the e-brake engaged) is in STOP, not CAN mode: nothing latched.
    deadline_s = _oracle().timing.deadline_s(OracleCause.CAN_IMPOSTOR)
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.world.gpio["motors_enable"].set(True)
    oracle.fault(OracleCause.CAN_IMPOSTOR, True, 1.0)
    oracle.fault(OracleCause.CAN_IMPOSTOR, False, 1.0 + deadline_s + 0.1)
    assert _drives_after_re_enable(oracle, 2.0) == []


def test_a_second_sender_met_with_the_motors_off_may_never_have_latched() -> None:
    # verify seed 0, campaign 204: a 5 ms glimpse of STOP left the robot standing while the
    # oracle allowed it to drive; CAN_UNTRUSTED latches only in CAN mode.
    deadline_s = _oracle().timing.deadline_s(OracleCause.CAN_IMPOSTOR)
    oracle = _second_sender(deadline_s + 0.1, motors_enabled=False)
    assert _drives_after_re_enable(oracle, 2.0) == []


def test_a_second_sender_after_another_stop_may_never_have_latched() -> None:
    # A remote stop first: the robot may have left CAN mode before the id was distrusted, and
    # CAN_UNTRUSTED latches only in CAN mode.
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.REMOTE_STOP, True, 1.0)
    oracle.fault(OracleCause.CAN_IMPOSTOR, True, 1.01)
    oracle.fault(OracleCause.CAN_IMPOSTOR, False, 1.5)
    oracle.fault(OracleCause.REMOTE_STOP, False, 1.6)
    assert _drives_after_re_enable(oracle, 2.0) == []


# --- H4 with a dead wheel sensor -------------------------------------------------------------


def _reversing_at(speed_mps: float, died_at_mps: float, brake_failed: bool = False) -> list[str]:
    oracle = _oracle()
    world = oracle.world
    world.vehicle.state = replace(world.vehicle.state, speed_mps=died_at_mps)
    oracle.sensor_dies()
    oracle.hydrobrake_fails(brake_failed)
    world.vehicle.state = replace(world.vehicle.state, speed_mps=speed_mps)
    world.gpio["motors_reverse"].set(True)
    _only(oracle, H4, 1.0, enable=True, throttle_volts=1.0)
    return [v.invariant for v in oracle.violations]


def test_h4_flags_a_reversal_at_speed_after_the_wheel_sensor_died_noticeably() -> None:
    assert _reversing_at(0.5, died_at_mps=1.5) == ["H4"]


def test_h4_leaves_a_double_fault_alone_the_sensor_dead_and_the_hydraulic_brake_failed() -> None:
    assert _reversing_at(0.5, died_at_mps=1.5, brake_failed=True) == []


def test_a_sensor_that_died_unnoticed_holds_the_robot_to_the_speed_it_died_at() -> None:
    unnoticed_mps = _oracle().timing.unnoticed_death_mps
    assert unnoticed_mps == pytest.approx(0.3 + 15.0 * 0.010)  # step tolerance + a period's braking
    assert _reversing_at(0.21, died_at_mps=0.4) == []  # seed 0, campaign 678
    assert _reversing_at(0.41, died_at_mps=0.4) == ["H4"]


# --- a glimpse of STOP that no frame showed -----------------------------------------------------


def test_a_glimpse_of_stop_no_frame_showed_does_not_bring_on_a_stop_already_pending() -> None:
    # The sequence test (hypothesis, 2026-11-25): handed over to CAN, the computer falls silent,
    # and a 5 ms flick to STOP that no frame showed. The controller stops when CAN_LOST latches;
    # the oracle held it to the flick's deadline instead.
    steps = [
        Step(0.2, "arm", RC),
        Step(0.15, "rc_throttle", 0.0),
        Step(0.5, "handover", 0.0),
        Step(0.125, "can_link", False),
        Step(0.05078125, "flick", 0.005),
    ]
    assert run_campaign(default_sim_config(), steps).findings == []


def test_a_pending_stop_keeps_its_deadline_across_an_unseen_glimpse_but_not_a_seen_stop() -> None:
    oracle = _oracle()
    _armed_in_can(oracle)
    oracle.fault(OracleCause.CAN_LOST, True, 1.0)
    can_deadline_s = oracle.ledger.deadline_s
    assert can_deadline_s is not None
    oracle.set_switch(ControlMode.STOP, 1.05)
    oracle.set_switch(CAN, 1.055)  # shorter than a frame: perhaps never seen
    assert oracle.ledger.deadline_s == can_deadline_s
    oracle.set_switch(ControlMode.STOP, 1.06)
    oracle.set_switch(CAN, 1.09)  # 30 ms at STOP: the frames showed it
    assert oracle.ledger.deadline_s == 1.06 + oracle.timing.deadline_s(OracleCause.SWITCH_STOP)


def test_a_robot_without_a_wheel_sensor_is_judged_as_one_whose_sensor_died_at_power_up() -> None:
    """No speed to trust from the start, and none that a fault could take away or give back:
    H4 holds at the standstill threshold (the no-sensor rule must stop the robot first)."""
    oracle = _oracle(replace(default_sim_config(), backend="linux"))
    assert oracle.plant.sensor_dead
    assert oracle.plant.died_at_mps == 0.0
    oracle.sensor_restored()
    assert oracle.plant.sensor_dead
    assert _oracle().plant.sensor_dead is False


def test_campaigns_on_a_robot_without_sensors_drive_on_the_no_sensor_rules_and_hold() -> None:
    robot = replace(default_sim_config(), backend="linux")
    outcomes = [run_campaign(robot, draw_campaign(0, index), index) for index in range(6)]
    assert sum(outcome.checks for outcome in outcomes) > 0
    assert [finding for outcome in outcomes for finding in outcome.findings] == []
