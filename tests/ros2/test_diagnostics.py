"""The diagnostics' content: every error flag in one subsystem, latched causes named as ERROR,
stale reports STALE, the link's and the inputs' figures."""

from __future__ import annotations

from dataclasses import replace

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, Gear, ModeReport, Report, StatusReport, WheelSpeedReport
from bywire.protocol import dbc
from bywire.ros2.diagnostics import (
    FLAG_GROUPS,
    RECENT_S,
    REFUSING_S,
    Level,
    LinkHealth,
    flag_statuses,
    inputs_status,
    link_status,
    log_lines,
    mode_line,
    mode_status,
    statuses,
)
from bywire.ros2.robot import RobotStatus, robot_status
from bywire.teleop.reports import ReportView, fold

LATCHED = RobotStatus(
    reporting=True,
    report_age_s=0.01,
    mode=ControlMode.STOP,
    latched=True,
    flags=ErrorFlag.REMOTE_STOP | ErrorFlag.CAN_COMMAND_REJECTED,
)


def test_every_flag_belongs_to_exactly_one_subsystem() -> None:
    for flag in ErrorFlag:
        owners = [name for name, members in FLAG_GROUPS.items() if flag in members]
        assert len(owners) == 1, (flag, owners)


def test_a_latched_cause_is_named_and_an_error() -> None:
    status = mode_status(LATCHED, engaged=False, remote_stop=True)
    assert status.level is Level.ERROR
    assert status.message == "STOP latched: REMOTE_STOP"
    assert ("latched_causes", "REMOTE_STOP") in status.values
    commands = next(s for s in flag_statuses(LATCHED) if s.name == "bywire: CAN commands")
    assert commands.level is Level.ERROR
    assert ("REMOTE_STOP", "latched") in commands.values
    assert ("CAN_COMMAND_REJECTED", "up") in commands.values


def test_a_flag_that_is_not_a_latched_cause_is_a_warning() -> None:
    driving = RobotStatus(
        True, 0.01, ControlMode.CAN, flags=ErrorFlag.IBUS_CHECKSUM, speed_trusted=True
    )
    rc = next(s for s in flag_statuses(driving) if s.name == "bywire: RC link")
    assert rc.level is Level.WARN
    assert rc.message == "IBUS_CHECKSUM"
    others = [s for s in flag_statuses(driving) if s.name != "bywire: RC link"]
    assert {s.level for s in others} == {Level.OK}
    assert mode_status(driving, engaged=True, remote_stop=False).level is Level.OK


def test_an_unknown_speed_is_an_error_that_names_why() -> None:
    """Issue 41 finding 6: the bridge will not drive on a speed it cannot trust."""
    faulted = RobotStatus(True, 0.01, ControlMode.CAN, flags=ErrorFlag.SPEED_SENSOR_FAULT)
    status = mode_status(faulted, engaged=True, remote_stop=False)
    assert status.level is Level.ERROR
    assert "SPEED_SENSOR_FAULT" in status.message
    unheard = RobotStatus(True, 0.01, ControlMode.CAN, speed_measured=True)  # flags unknown
    assert "ErrorReport" in mode_status(unheard, engaged=True, remote_stop=False).message
    unmeasured = RobotStatus(True, 0.01, ControlMode.CAN)  # no wheel sensor (albert): row 60
    status = mode_status(unmeasured, engaged=True, remote_stop=False)
    assert status.level is Level.ERROR
    assert "measures no wheel speed" in status.message
    trusted = RobotStatus(True, 0.01, ControlMode.CAN, speed_trusted=True)
    assert mode_status(trusted, engaged=True, remote_stop=False).level is Level.OK


def test_without_reports_everything_of_the_robot_is_stale() -> None:
    silent = RobotStatus(reporting=False, report_age_s=None)
    assert mode_status(silent, engaged=False, remote_stop=False).level is Level.STALE
    assert {s.level for s in flag_statuses(silent)} == {Level.STALE}
    assert link_status(LinkHealth(bus="active"), silent).level is Level.ERROR


def test_the_link_and_inputs_carry_their_figures() -> None:
    health = LinkHealth(
        bus="active",
        frames_sent=120,
        send_errors=2,
        command_age_s=0.05,
        refused=3,
        last_refusal="header stamp older than max_stamp_age_s",
        last_refusal_age_s=1.0,
    )
    link = link_status(health, LATCHED)
    assert link.level is Level.WARN
    assert ("send_errors", "2") in link.values
    inputs = inputs_status(health, StatusReport(12, 0, 4095, 20))
    assert inputs.level is Level.WARN
    assert ("robot_can_command_age_ms", "20") in inputs.values
    assert ("commands_refused", "3") in inputs.values
    stale_refusal = LinkHealth(last_refusal="x", last_refusal_age_s=60.0)
    assert inputs_status(stale_refusal, None).level is Level.OK


def test_one_array_has_mode_each_group_link_and_inputs() -> None:
    names = [
        s.name for s in statuses(LATCHED, LinkHealth(), None, engaged=False, remote_stop=False)
    ]
    assert len(names) == len(set(names)) == 1 + len(FLAG_GROUPS) + 2
    assert all(name.startswith("bywire: ") for name in names)


def test_the_mode_line_names_mode_arming_enabling_and_causes() -> None:
    driving = RobotStatus(True, 0.01, ControlMode.CAN, armed=True)
    assert mode_line(driving, engaged=True) == "CAN armed enabled"
    assert mode_line(driving, engaged=False) == "CAN armed"
    assert mode_line(LATCHED, engaged=False) == "STOP latched REMOTE_STOP"
    assert mode_line(RobotStatus(False, None), engaged=False) == "UNKNOWN no reports"


def test_a_starved_link_is_a_warning() -> None:
    driving = RobotStatus(True, 0.01, ControlMode.CAN)
    assert link_status(LinkHealth(bus="active", max_period_s=0.021), driving).level is Level.OK
    starved = link_status(LinkHealth(bus="active", max_period_s=0.08), driving)
    assert starved.level is Level.WARN
    assert "0.080 s" in starved.message


def test_commands_refused_while_they_keep_arriving_are_an_error_after_the_stated_time() -> None:
    """Issue 41 finding 8: WARN while commands are refused, ERROR once none has been accepted
    for `REFUSING_S` while they keep arriving, back to OK `RECENT_S` after the last refusal."""
    refusing = LinkHealth(
        refused=30,
        last_refusal="header stamp older than max_stamp_age_s",
        last_refusal_age_s=0.01,
        arrival_age_s=0.02,
        refusing_for_s=REFUSING_S - 0.01,
    )
    assert inputs_status(refusing, None).level is Level.WARN
    starved = replace(refusing, refusing_for_s=REFUSING_S)
    error = inputs_status(starved, None)
    assert error.level is Level.ERROR
    assert "header stamp older" in error.message
    silent = replace(starved, arrival_age_s=REFUSING_S + 0.01)  # they stopped arriving
    assert inputs_status(silent, None).level is Level.WARN
    accepted = replace(starved, refusing_for_s=None, accepted_age_s=0.0)
    assert inputs_status(accepted, None).level is Level.WARN
    assert inputs_status(replace(accepted, last_refusal_age_s=RECENT_S), None).level is Level.OK


def test_each_change_of_level_is_one_log_line() -> None:
    ok = inputs_status(LinkHealth(), None)
    warn = inputs_status(LinkHealth(last_refusal="x", last_refusal_age_s=0.0), None)
    logged, lines = log_lines({}, [ok, ok])
    assert lines == []
    for _ in range(3):  # the same level again: nothing more
        logged, lines = log_lines(logged, [warn])
        if lines:
            assert lines == [(Level.WARN, "bywire: inputs WARN: refused: x")]
    logged, lines = log_lines(logged, [warn, ok])
    assert lines == [(Level.OK, "bywire: inputs OK: OK")]
    flags = flag_statuses(RobotStatus(True, 0.01, ControlMode.CAN, flags=ErrorFlag.IBUS_CHECKSUM))
    assert log_lines(logged, flags)[1] == []  # the flag groups are not logged


def test_a_pressed_estop_has_its_own_status_and_is_named_as_a_latched_cause() -> None:
    pressed = RobotStatus(True, 0.01, ControlMode.STOP, latched=True, flags=ErrorFlag.ESTOP_PRESSED)
    assert mode_status(pressed, engaged=False, remote_stop=False).message == (
        "STOP latched: ESTOP_PRESSED"
    )
    estop = next(s for s in flag_statuses(pressed) if s.name == "bywire: emergency stop")
    assert estop.level is Level.ERROR
    assert ("ESTOP_PRESSED", "latched") in estop.values


def test_the_robots_speed_limit_acting_is_shown_in_the_mode_status() -> None:
    driving = RobotStatus(True, 0.01, ControlMode.CAN, armed=True, speed_trusted=True)
    free = mode_status(driving, engaged=True, remote_stop=False)
    assert dict(free.values)["speed_limited"] == "false"
    assert free.message == "CAN mode, enabled"
    held = mode_status(replace(driving, speed_limited=True), engaged=True, remote_stop=False)
    assert dict(held.values)["speed_limited"] == "true"
    assert held.message == "CAN mode, enabled, held to the robot's speed limit"
    assert held.level is Level.OK  # a limit that acts is no fault


def _folded(*reports: Report) -> ReportView:
    view = ReportView()
    for report in reports:
        view = fold(view, *dbc.encode_report(report), 1.0)
    return view


def test_the_status_reads_speed_limited_off_the_wheel_speed_report() -> None:
    mode = ModeReport(Gear.FORWARD, ControlMode.CAN, False, False, True)
    limited = _folded(mode, WheelSpeedReport(2.0, 2.0, True, speed_limited=True))
    assert robot_status(limited, 1.01, 0.2).speed_limited
    free = _folded(mode, WheelSpeedReport(1.0, 1.0, True))
    assert not robot_status(free, 1.01, 0.2).speed_limited
