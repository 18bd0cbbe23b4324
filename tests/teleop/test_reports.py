"""The teleop's view of the robot: reports folded in, shown with names, units and ages."""

from __future__ import annotations

from bywire.error_flags import ErrorFlag
from bywire.model import (
    ControlMode,
    ErrorReport,
    Gear,
    LightsReport,
    ModeReport,
    Report,
    StatusReport,
    SteeringReport,
    WheelSpeedReport,
)
from bywire.protocol import dbc
from bywire.teleop.reports import ReportView, command_lines, fold, report_lines, speed_mps
from bywire.teleop.state import TeleopState, press

REPORTS: tuple[Report, ...] = (
    ModeReport(Gear.REVERSE, ControlMode.CAN, False, False, True),
    ErrorReport(ErrorFlag.RC_TIMEOUT | ErrorFlag.REMOTE_STOP),
    WheelSpeedReport(1.0, 1.5, True),
    SteeringReport(-0.25, -0.2, True),
    LightsReport(True, True, False, False, False, True, False),
    StatusReport(12, 3, 40, 20),
)


def view_of(*reports: Report, at_s: float = 1.0) -> ReportView:
    view = ReportView()
    for report in reports:
        view = fold(view, *dbc.encode_report(report), at_s)
    return view


def test_every_report_is_decoded_and_kept_with_its_arrival_time() -> None:
    view = view_of(*REPORTS, at_s=2.0)
    for report in REPORTS:
        assert view.get(type(report)) == report
        assert view.age_s(type(report), 2.25) == 0.25


def test_before_any_report_everything_reads_never_seen() -> None:
    lines = report_lines(ReportView(), 0.0)
    assert all("—" in line for line in lines)
    assert speed_mps(ReportView()) is None


def test_the_panel_names_mode_gear_speed_steering_lights_flags_and_ages() -> None:
    text = "\n".join(report_lines(view_of(*REPORTS), 1.1))
    assert "mode CAN  gear REVERSE  armed" in text
    assert "speed +1.25 m/s (+4.5 km/h)" in text
    assert "steering -0.25 (measured -0.20)" in text
    assert "lights brake reverse low-beam" in text
    assert "errors RC_TIMEOUT REMOTE_STOP" in text
    assert "status uptime 12 s  overruns 3  rc age 40 ms  can age 20 ms" in text
    assert "mode 100 ms" in text


def test_an_unmeasured_wheel_speed_reads_no_reading_not_standstill() -> None:
    """Row 60: a robot without a wheel sensor sends 0 m/s with `measured_valid` 0."""
    view = view_of(WheelSpeedReport(0.0, 0.0, False))
    assert speed_mps(view) is None
    text = "\n".join(report_lines(view, 1.1))
    assert "speed no reading" in text
    assert "0.00 m/s" not in text


def test_a_latched_stop_and_no_errors_read_plainly() -> None:
    mode = ModeReport(Gear.NEUTRAL, ControlMode.STOP, True, True, False)
    view = view_of(mode, ErrorReport(ErrorFlag(0)))
    text = "\n".join(report_lines(view, 1.0))
    assert "mode STOP  gear NEUTRAL  LATCHED E-STOP" in text
    assert "errors none" in text


def test_a_robot_in_stop_says_why_on_a_line_of_its_own() -> None:
    """Issue 32, defect 4: teleop showed no warning when its gaps stopped the robot."""
    mode = ModeReport(Gear.FORWARD, ControlMode.STOP, True, True, True)
    flags = ErrorFlag.CAN_COMMAND_TIMEOUT | ErrorFlag.CAN_COMMAND_REJECTED
    lines = report_lines(view_of(mode, ErrorReport(flags)), 1.0)
    assert lines[1] == "robot in STOP (latched): CAN_COMMAND_TIMEOUT, CAN_COMMAND_REJECTED"
    driving = report_lines(view_of(*REPORTS), 1.0)
    assert not any(line.startswith("robot in STOP") for line in driving)


def test_the_newest_report_wins() -> None:
    first, second = WheelSpeedReport(1.0, 1.0, True), WheelSpeedReport(-0.5, -0.5, True)
    view = fold(view_of(first, at_s=1.0), *dbc.encode_report(second), 1.5)
    assert speed_mps(view) == -0.5
    assert view.age_s(WheelSpeedReport, 1.5) == 0.0


def test_commands_and_foreign_frames_are_ignored_and_bad_reports_counted() -> None:
    view = view_of(*REPORTS)
    movement_id = dbc.command_ids()[0]
    assert fold(view, movement_id, bytes(8), 3.0) is view
    assert fold(view, 0x7FF, b"", 3.0) is view
    mode_id = dbc.frame_id(ModeReport)
    damaged = fold(view, mode_id, b"\x00", 3.0)
    assert damaged.bad_frames == 1
    assert damaged.get(ModeReport) == REPORTS[0]


def test_the_command_lines_show_what_goes_out() -> None:
    state = TeleopState()
    for key in ("f", "up", "right", "h", "s", "e"):
        state = press(state, key, 0.0)
    text = "\n".join(command_lines(state))
    assert "steering +0.10  throttle 0.10  brake 0.00  gear FORWARD" in text
    assert "lights hazard  control REMOTE-STOP re-enable" in text
