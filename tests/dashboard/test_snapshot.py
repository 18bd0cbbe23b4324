"""The dashboard's snapshot of a whole simulated robot on virtual time, and its panels' text."""

from __future__ import annotations

import pytest

from bywire.config import default_sim_config
from bywire.dashboard.feed import SnapshotFeed
from bywire.dashboard.snapshot import DashboardSnapshot, snapshot
from bywire.dashboard.view import (
    TASK_COLUMNS,
    actuator_panel,
    command_panel,
    idle_cells,
    input_panel,
    mode_panel,
    task_cells,
)
from bywire.runtime.schedule import SCHEDULE
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from tests.system.harness import Robot

TABLE_1 = {spec.name: spec.rate_hz for spec in SCHEDULE}


def _armed_rc(until_s: float = 1.0) -> Robot:
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(0.5))
    robot.run(until_s)
    return robot


def test_no_snapshot_before_the_first_decision() -> None:
    robot = Robot.build()
    with pytest.raises(ValueError, match="decision"):
        snapshot(robot.runtime, 0.0, 0.0)


def test_driving_by_rc_shows_the_mode_the_command_its_source_and_the_outputs() -> None:
    robot = _armed_rc()
    snap = snapshot(robot.runtime, robot.clock.now(), wall_elapsed_s=1.0)
    assert snap.elapsed_s == pytest.approx(1.0)
    assert (snap.mode.mode, snap.mode.latch, snap.mode.armed) == ("RC", None, True)
    assert snap.command.source.startswith("RC transmitter")
    assert snap.command.throttle_norm == pytest.approx(0.5, abs=0.02)
    assert snap.command.gear == "FORWARD"
    out = snap.actuators
    assert out.throttle_volts > 0.0
    assert out.motors_enabled
    assert out.direction == "forward"
    assert not out.ebrake_engaged
    assert out.steering_pulse_ms == pytest.approx(1.5, abs=0.01)
    assert snap.error_flags == ()
    inputs = snap.inputs
    assert inputs.rc_age_s is not None
    assert inputs.rc_age_s < 0.02
    assert inputs.ibus_frames > 100
    assert inputs.reports_sent > 0


def test_the_task_table_has_table_1_with_measured_rates_and_an_idle_share() -> None:
    robot = _armed_rc()
    snap = snapshot(robot.runtime, robot.clock.now(), wall_elapsed_s=1.0)
    rates = {row.name: row.rate_hz for row in snap.tasks}
    assert list(rates) == list(TABLE_1)
    for name, nominal_hz in TABLE_1.items():
        assert rates[name] == pytest.approx(nominal_hz, rel=0.03)
    shares = sum(row.runtime_share_pct for row in snap.tasks)
    assert snap.idle_share_pct == pytest.approx(100.0 - shares)
    assert 0.0 < snap.idle_share_pct < 100.0
    assert all(row.overruns == 0 for row in snap.tasks)


def test_a_lost_rc_link_shows_stop_latched_and_rc_timeout_by_name() -> None:
    robot = _armed_rc()
    robot.at(1.0, robot.world.rc.link_lost)
    robot.runtime.run(until_s=1.3)
    snap = snapshot(robot.runtime, robot.clock.now(), wall_elapsed_s=1.3)
    assert (snap.mode.mode, snap.mode.latch, snap.mode.armed) == ("STOP", "RC_LOST", False)
    assert "RC_TIMEOUT" in snap.error_flags
    assert snap.command.source.startswith("none")
    assert snap.actuators.ebrake_engaged
    assert not snap.actuators.motors_enabled
    assert snap.actuators.throttle_volts == 0.0
    assert snap.inputs.rc_age_s is not None
    assert snap.inputs.rc_age_s > 0.25
    text = str(mode_panel(snap))
    assert "mode STOP  LATCHED" in text
    assert "latched by RC_LOST: RC frames stopped arriving" in text
    assert "error flags: RC_TIMEOUT" in text


def test_the_panels_say_what_the_snapshot_holds() -> None:
    robot = _armed_rc()
    snap = snapshot(robot.runtime, robot.clock.now(), wall_elapsed_s=1.0)
    assert "mode RC  armed" in str(mode_panel(snap))
    assert "error flags: none" in str(mode_panel(snap, "scenario ended"))
    assert "scenario ended" in str(mode_panel(snap, "scenario ended"))
    commands = str(command_panel(snap))
    assert "source   RC transmitter (IBUS)" in commands
    assert "gear     FORWARD" in commands
    assert "brake    0.00" in commands  # never "-0.00"
    actuators = str(actuator_panel(snap))
    assert "steering pulse 1.500 ms" in actuators
    assert "motors enabled forward" in actuators
    assert "e-brake released" in actuators
    assert "CAN rejected: none" in str(input_panel(snap))
    cells = task_cells(snap.tasks[0])
    assert len(cells) == len(TASK_COLUMNS)
    assert cells[:3] == ("steering", "100.0 Hz", "100 Hz")
    assert idle_cells(snap)[0] == "idle"
    assert idle_cells(snap)[3] == f"{snap.idle_share_pct:.2f} %"


def _modes_of(scenario: str, duration_s: float) -> tuple[list[DashboardSnapshot], SnapshotFeed]:
    sim = SimRun(default_sim_config(), find_scenario(scenario), duration_s=duration_s)
    feed = SnapshotFeed(sim.runtime, wall_clock=sim.world.clock.now).attach()
    seen: list[DashboardSnapshot] = []

    def keep(_now: float) -> None:
        latest = feed.latest()
        if latest is not None and (not seen or latest is not seen[-1]):
            seen.append(latest)

    sim.runtime.on_cycle.append(keep)
    sim.run()
    return seen, feed


def test_the_feed_follows_the_test_course_from_stop_through_rc_to_can_at_10_hz() -> None:
    seen, feed = _modes_of("test-course", 11.0)
    modes = [snap.mode.mode for snap in seen]
    changes = [mode for i, mode in enumerate(modes) if i == 0 or modes[i - 1] != mode]
    assert changes == ["STOP", "RC", "CAN"]
    assert feed.taken == len(seen)
    assert len(seen) == pytest.approx(110, abs=2)
    can = seen[-1]
    assert can.command.source.startswith("higher-level computer")
    assert can.inputs.can_movement_age_s is not None
    assert can.inputs.can_movement_age_s < 0.05


def test_the_rc_link_lost_scenario_shows_rc_timeout_then_stop_stays_latched() -> None:
    seen, _feed = _modes_of("rc-link-lost", 4.5)  # link lost at 3.0 s, back at 4.0 s

    def at(time_s: float) -> DashboardSnapshot:
        return min(seen, key=lambda snap: abs(snap.elapsed_s - time_s))

    assert at(2.5).mode.mode == "RC"
    lost = at(3.5)
    assert (lost.mode.mode, lost.mode.latch) == ("STOP", "RC_LOST")
    assert "RC_TIMEOUT" in lost.error_flags
    assert "error_led" in lost.actuators.lights_on
    back = seen[-1]
    assert (back.mode.mode, back.mode.latch) == ("STOP", "RC_LOST")
    # A latched STOP names its cause: the flag stays up until the operator re-arms.
    assert "RC_TIMEOUT" in back.error_flags
