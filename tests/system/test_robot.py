"""System tests: the real controller drives the simulated robot on virtual time (issue 3 list)."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path

import pytest

from bywire.config import default_sim_config
from bywire.error_flags import ErrorFlag
from bywire.model import LIGHTS_OFF, ControlMode, ErrorReport, Gear, ModeReport, StatusReport
from bywire.sim.runner import SimRun
from bywire.sim.scenario import load_scenario
from tests.system.harness import Robot

TIMEOUT_S = 0.100
CONTROL_PERIOD_S = 0.010
SCENARIOS = Path(__file__).resolve().parents[2] / "src" / "bywire" / "scenarios"


def rc_driving(throttle: float = 0.6, steering: float = 0.0) -> Robot:
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(throttle))
    robot.at(0.3, lambda: robot.world.rc.set_steering(steering))
    return robot


def can_driving(throttle: float = 0.5, **lights: bool) -> Robot:
    robot = Robot.build()
    hlc = robot.world.hlc
    robot.at(0.0, lambda: hlc.set_movement(0.0, 0.0, 0.3, Gear.FORWARD))
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_mode(ControlMode.CAN))
    robot.at(0.5, lambda: hlc.set_movement(0.2, throttle, 0.0, Gear.FORWARD))
    robot.at(0.5, lambda: hlc.set_lights(replace(LIGHTS_OFF, **lights)))
    return robot


def test_rc_drives_the_robot() -> None:
    robot = rc_driving(throttle=0.6, steering=0.5)
    robot.run(3.0)
    assert robot.runtime.outputs is not None
    assert robot.runtime.outputs.mode is ControlMode.RC
    assert robot.throttle_volts(2.0) == pytest.approx(3.0, abs=0.01)
    assert robot.level("motors_enable", 2.0)
    assert robot.level("motors_forward", 2.0)
    assert not robot.level("ebrake_release", 0.05)
    assert robot.level("ebrake_release", 2.0)
    assert robot.world.pwm.steering.pulse_at(2.0) == pytest.approx(0.00175, abs=1e-5)
    assert robot.world.vehicle.state.speed_mps > 1.0
    assert robot.world.vehicle.state.steering_norm > 0.4


def test_can_drives_the_robot() -> None:
    robot = can_driving(throttle=0.5)
    robot.run(3.0)
    assert robot.runtime.outputs is not None
    assert robot.runtime.outputs.mode is ControlMode.CAN
    assert robot.throttle_volts(2.5) == pytest.approx(2.5, abs=0.01)
    assert robot.world.vehicle.state.speed_mps > 0.8
    assert robot.runtime.can.rejected.total() == 0


def test_the_switch_selects_can_rc_and_stop() -> None:
    robot = can_driving(throttle=0.0)
    rc = robot.world.rc
    robot.at(1.0, lambda: rc.set_mode(ControlMode.RC))
    robot.at(1.5, lambda: rc.set_mode(ControlMode.CAN))
    robot.at(2.0, lambda: rc.set_mode(ControlMode.STOP))
    robot.run(2.5)
    modes = [mode for _, mode in robot.runtime.mode_log]
    assert modes == [ControlMode.STOP, ControlMode.RC, ControlMode.CAN, ControlMode.RC,
                     ControlMode.CAN, ControlMode.STOP]  # fmt: skip
    switch_times = [time for time, _ in list(robot.runtime.mode_log)[1:]]
    expected = [0.2, 0.3, 1.0, 1.5, 2.0]
    # The switch is read from the next IBUS frame (one period plus its wire time); a move away
    # from STOP, or between RC and CAN, counts after 3 frames in a row (the debounce).
    frames = [3, 3, 3, 3, 1]
    assert all(
        0 <= got - want <= count * 0.0077 + 0.003
        for got, want, count in zip(switch_times, expected, frames, strict=True)
    )


def test_stop_engages_the_emergency_brake_and_zeroes_throttle() -> None:
    robot = rc_driving(throttle=0.8)
    robot.at(2.0, lambda: robot.world.rc.set_mode(ControlMode.STOP))
    robot.run(3.0)
    assert robot.throttle_volts(1.9) > 3.0
    safe_at = robot.first_time(2.0, robot.safe_at)
    assert safe_at is not None
    assert safe_at - 2.0 <= 0.0077 + 0.003  # the next frame carries the switch, then at once
    hydrobrake = robot.world.pwm.hydrobrake
    assert hydrobrake.pulse_at(2.5) == pytest.approx(hydrobrake.period_s)  # STOP brakes fully
    assert robot.world.vehicle.state.speed_mps == pytest.approx(0.0, abs=1e-6)


def test_rc_frames_stop_means_stop_within_timeout_plus_one_control_period() -> None:
    robot = rc_driving(throttle=0.5)
    robot.at(2.0, robot.world.rc.link_lost)
    robot.run(3.0)
    assert robot.level("motors_enable", 1.99)
    safe_at = robot.first_time(2.0, robot.safe_at)
    assert safe_at is not None
    assert safe_at - 2.0 <= TIMEOUT_S + CONTROL_PERIOD_S
    assert safe_at - 2.0 >= TIMEOUT_S - 0.0077 - 0.003  # not before the timeout: no false alarm
    assert robot.runtime.outputs is not None
    assert robot.runtime.outputs.error_flags & ErrorFlag.RC_TIMEOUT


def test_can_commands_stop_in_can_mode_means_stop_not_rc() -> None:
    robot = can_driving(throttle=0.5)
    robot.at(2.0, robot.world.hlc.silence)
    robot.run(3.0)
    safe_at = robot.first_time(2.0, robot.safe_at)
    assert safe_at is not None
    assert safe_at - 2.0 <= TIMEOUT_S + CONTROL_PERIOD_S
    assert robot.runtime.mode_log[-1][1] is ControlMode.STOP
    assert all(mode is not ControlMode.RC for time, mode in robot.runtime.mode_log if time > 2.0)


@pytest.mark.parametrize(("brake_norm", "duty"), [(0.3, 0.0), (0.5, 0.0), (0.75, 0.5), (1.0, 1.0)])
def test_hydraulic_brake_duty_follows_figure_13(brake_norm: float, duty: float) -> None:
    robot = rc_driving(throttle=-brake_norm)
    robot.run(1.0)
    hydrobrake = robot.world.pwm.hydrobrake
    assert hydrobrake.pulse_at(0.9) / hydrobrake.period_s == pytest.approx(duty, abs=0.01)
    assert hydrobrake.duty == 1.0  # and the run ends with the outputs safe


@pytest.mark.parametrize(("brake_norm", "lit"), [(0.05, False), (0.2, True)])
def test_brake_lights_above_ten_percent(brake_norm: float, lit: bool) -> None:
    robot = rc_driving(throttle=-brake_norm)
    robot.run(1.0)
    assert robot.level("brake_light", 0.9) is lit


def test_reverse_lights_in_reverse() -> None:
    robot = rc_driving(throttle=0.0)
    robot.at(0.5, lambda: robot.world.rc.set_gear(Gear.REVERSE))
    robot.at(0.6, lambda: robot.world.rc.set_pedal(0.4))
    robot.run(2.0)
    assert not robot.level("reverse_light", 0.45)
    assert robot.level("reverse_light", 1.9)
    assert robot.world.vehicle.state.speed_mps < -0.1


@pytest.mark.parametrize("side", ["turn_left", "turn_right"])
def test_turn_signals_blink_at_one_and_a_half_hertz(side: str) -> None:
    robot = can_driving(throttle=0.0, **{side: True})
    robot.run(12.0)
    rising = [stamp for stamp in robot.rising_edges(f"{side}_light") if stamp > 0.6]
    periods = [later - earlier for earlier, later in itertools.pairwise(rising)]
    assert len(periods) >= 14
    assert sum(periods) / len(periods) == pytest.approx(1 / 1.5, abs=0.005)
    assert all(abs(period - 1 / 1.5) <= 0.05 + 1e-9 for period in periods)  # lights run at 20 Hz
    other = "turn_right" if side == "turn_left" else "turn_left"
    assert not any(level for _, level in robot.world.gpio[f"{other}_light"].history)


def test_error_led_on_any_error_flag_and_off_on_recovery() -> None:
    robot = rc_driving(throttle=0.0)
    robot.at(1.0, lambda: robot.world.rc.corrupt_next_frames(1))
    robot.run(3.0)
    assert not robot.level("error_led", 0.9)
    assert robot.level("error_led", 1.1)
    assert not robot.level("error_led", 2.9)  # recoverable: IBUS_CHECKSUM clears
    assert robot.runtime.ibus.parser.stats.checksum_errors == 1


def test_reports_arrive_at_50_hz() -> None:
    robot = rc_driving(throttle=0.3)
    robot.run(3.0)
    for kind in (ModeReport, StatusReport):
        arrivals = [stamp for stamp in robot.world.hlc.arrivals(kind) if stamp > 1.0]
        periods = [later - earlier for earlier, later in itertools.pairwise(arrivals)]
        assert len(arrivals) == pytest.approx(100, abs=1)
        # Sent in the same pass as the 100 Hz writes, after them: within the task jitter of
        # their deadline, never drifting from it.
        assert all(period == pytest.approx(0.020, abs=0.001) for period in periods)
        mean_period_s = (arrivals[-1] - arrivals[0]) / (len(arrivals) - 1)
        assert mean_period_s == pytest.approx(0.020, abs=1e-5)
    latest = robot.world.hlc.latest(ModeReport)
    assert isinstance(latest, ModeReport)
    assert latest.control_mode is ControlMode.RC


def test_outputs_are_safe_before_the_first_input_and_after_the_run() -> None:
    robot = Robot.build()
    robot.run(0.5)
    assert robot.safe_at(0.0)
    assert robot.safe_at(0.5)
    assert robot.world.pwm.hydrobrake.duty == 1.0


def test_the_test_course_meets_every_expectation() -> None:
    scenario = load_scenario(SCENARIOS / "test-course.toml")
    record = SimRun(default_sim_config(), scenario).run()
    failed = [verdict.expectation.describe() for verdict in record.verdicts if not verdict.passed]
    assert failed == []
    assert len(record.verdicts) >= 5
    assert record.samples[-1].distance_m > 20.0


def test_unplugged_bus_does_not_starve_the_lights_task() -> None:
    """§5.2: with no mailbox ever freeing, the report task must give up, not spin."""
    robot = can_driving(throttle=0.3)
    robot.at(1.0, robot.world.bus.unplug)
    robot.run(5.0)
    tasks = {task.spec.name: task.stats for task in robot.runtime.tasks}
    assert tasks["lights"].runs == pytest.approx(5.0 * 20, abs=1)
    assert all(stats.overruns == 0 for stats in tasks.values())
    assert robot.runtime.tx_faults.count >= 150  # one refusal per report period, then back off
    assert robot.runtime.reports_sent <= 50 * 6 + 10  # a second of reports, then a full queue
    assert robot.level("error_led", 4.9)


def test_a_crash_inside_the_loop_still_ends_with_every_output_safe() -> None:
    robot = rc_driving(throttle=0.5)

    def crash(now: float) -> None:
        if now > 1.5:
            raise RuntimeError("a task failed")

    robot.runtime.on_cycle.append(crash)
    with pytest.raises(RuntimeError, match="a task failed"):
        robot.run(3.0)
    crashed_at = robot.clock.now()
    assert robot.level("motors_enable", crashed_at - 0.02)  # it was driving
    assert robot.safe_at(crashed_at)


def test_a_crash_ends_with_safe_outputs_then_a_last_report_that_names_it() -> None:
    robot = rc_driving(throttle=0.5)
    hlc, seen = robot.world.hlc, []

    def crash(now: float) -> None:
        seen.append(hlc.latest(ErrorReport))
        if now > 1.5:
            raise RuntimeError("a task failed")

    robot.runtime.on_cycle.append(crash)
    with pytest.raises(RuntimeError, match="a task failed") as raised:
        robot.run(3.0)
    crashed_at = robot.clock.now()
    assert robot.safe_at(crashed_at)
    assert not any(
        isinstance(report, ErrorReport) and ErrorFlag.TASK_CRASHED in report.flags
        for report in seen
    )
    robot.clock.advance(0.01)  # the bus carries the last frames the controller queued
    errors, mode = hlc.latest(ErrorReport), hlc.latest(ModeReport)
    assert isinstance(errors, ErrorReport)
    assert isinstance(mode, ModeReport)
    assert ErrorFlag.TASK_CRASHED in errors.flags
    assert (mode.control_mode, mode.estop_engaged, mode.stop_latched, mode.armed) == (
        ControlMode.STOP,
        True,
        True,
        False,
    )
    assert robot.off_at(crashed_at + 0.01)  # and nothing moved after it
    assert robot.runtime.crashed_by is raised.value


def test_a_loop_that_ends_as_asked_sends_no_crash_report() -> None:
    robot = rc_driving(throttle=0.5)
    robot.run(2.0)
    robot.clock.advance(0.01)
    assert robot.runtime.crashed_by is None
    errors = robot.world.hlc.latest(ErrorReport)
    assert isinstance(errors, ErrorReport)
    assert ErrorFlag.TASK_CRASHED not in errors.flags
