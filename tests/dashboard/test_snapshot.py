"""The dashboard's model from real state messages of a simulated robot, and its panels' text."""

from __future__ import annotations

import pytest

from bywire.dashboard.snapshot import from_state
from bywire.dashboard.view import (
    PANEL_WIDTH,
    TASK_COLUMNS,
    actuator_panel,
    command_panel,
    flags_line,
    idle_cells,
    input_panel,
    mode_panel,
    task_cells,
)
from bywire.error_flags import ErrorFlag
from bywire.task_table import SCHEDULE
from tests.dashboard.states import driving_by_rc, full_throttle_limited, rc_lost

TABLE_1 = {spec.name: spec.rate_hz for spec in SCHEDULE}


def test_driving_by_rc_shows_the_mode_the_command_its_source_the_outputs_and_speed() -> None:
    snap = from_state(driving_by_rc())
    assert snap.elapsed_s == pytest.approx(0.98)  # the last 50 Hz capture before 1 s
    assert (snap.mode, snap.latched, snap.armed) == ("RC", (), True)
    assert snap.command.source.startswith("RC transmitter")
    assert snap.command.throttle_norm == pytest.approx(0.5, abs=0.02)
    assert snap.command.gear == "FORWARD"
    assert snap.speed_mps is not None
    assert snap.speed_mps > 0.0
    out = snap.actuators
    assert out.throttle_volts > 0.0
    assert out.dac_throttle_volts == pytest.approx(out.throttle_volts, abs=0.01)
    assert (out.motors_enabled, out.direction, out.ebrake_engaged) == (True, "forward", False)
    assert out.steering_pulse_ms == pytest.approx(1.5, abs=0.01)
    assert snap.error_flags == ()
    assert snap.inputs.rc_age_s is not None
    assert snap.inputs.rc_age_s < 0.02
    assert snap.inputs.rc_frames > 100
    assert snap.inputs.reports_sent > 0
    assert {task.name: task.nominal_rate_hz for task in snap.tasks} == TABLE_1
    assert 0.0 <= snap.idle_share_pct <= 100.0


def test_a_lost_rc_link_shows_stop_latched_with_its_flag() -> None:
    snap = from_state(rc_lost())
    assert (snap.mode, snap.armed) == ("STOP", False)
    assert "RC_LOST" in snap.latched
    assert "RC_TIMEOUT" in snap.error_flags
    panel = mode_panel(snap).plain
    assert "mode STOP  LATCHED" in panel
    assert "flags: 1 set (below)" in panel
    assert flags_line(snap).plain == "error flags: RC_TIMEOUT"
    assert actuator_panel(snap).plain.splitlines()[2].startswith("e-brake ENGAGED")


def test_every_flag_is_named_in_full_however_many_are_set() -> None:
    """Issue 32, defect 10: the mode panel cut the flags at 36 columns."""
    names = [str(flag.name) for flag in ErrorFlag][:6]
    snap = from_state({**rc_lost(), "error_flags": names})
    assert flags_line(snap).plain == "error flags: " + ", ".join(names)
    assert "6 set" in mode_panel(snap).plain


def test_every_panel_is_four_lines_that_fit_half_an_80_column_terminal() -> None:
    for state in (driving_by_rc(), rc_lost()):
        snap = from_state(state)
        for panel in (mode_panel, command_panel, actuator_panel, input_panel):
            lines = panel(snap).plain.split("\n")
            assert len(lines) == 4, (panel.__name__, lines)
            assert max(map(len, lines)) <= PANEL_WIDTH, (panel.__name__, lines)


def test_the_panels_say_what_the_robot_does() -> None:
    snap = from_state(driving_by_rc())
    assert "mode RC  armed" in mode_panel(snap).plain
    assert "speed " in mode_panel(snap).plain
    assert "m/s" in mode_panel(snap).plain
    assert "flags: none" in mode_panel(snap).plain
    assert "source RC transmitter" in command_panel(snap).plain
    assert "motors enabled forward" in actuator_panel(snap).plain
    assert "e-brake released" in actuator_panel(snap).plain
    assert "frames" in input_panel(snap).plain
    rows = {cells[0]: cells for cells in map(task_cells, snap.tasks)}
    assert rows["steering"][2] == "100 Hz"
    assert rows["lights"][1:3] == ("20.4 Hz", "20 Hz")  # 20 runs in 0.98 s, the first at 0
    assert len(rows["steering"]) == len(TASK_COLUMNS)
    assert idle_cells(snap)[3].endswith(" %")


def test_a_negative_zero_is_shown_as_zero() -> None:
    state = driving_by_rc()
    state["setpoint"]["brake_norm"] = -0.0
    assert "brake 0.00" in command_panel(from_state(state)).plain


def test_the_speed_limit_and_whether_it_acts_are_shown() -> None:
    limited = from_state(full_throttle_limited())
    assert (limited.speed_limit_mps, limited.speed_limited) == (2.0, True)
    assert limited.speed_mps is not None
    assert 1.6 < limited.speed_mps <= 2.0
    panel = mode_panel(limited).plain
    assert "limit 2, LIMITING" in panel
    assert max(map(len, panel.split("\n"))) <= PANEL_WIDTH
    free = from_state(driving_by_rc())  # a runtime without a limit
    assert (free.speed_limit_mps, free.speed_limited) == (None, False)
    assert "no limit" in mode_panel(free).plain
