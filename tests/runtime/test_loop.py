"""The runtime's pass: one clock reading, one decision, at most one write per output; bounded
memory; reports that carry what the sensors measured (issue 10, rows 13-15)."""

from __future__ import annotations

import gc
import itertools
from collections.abc import Callable
from dataclasses import replace

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.control import controller
from bywire.control.controller import ControlConfig, ControlInputs, ControlOutputs, ControlState
from bywire.error_flags import ErrorFlag
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, ErrorReport, Gear, SteeringReport, WheelSpeedReport
from bywire.runtime import loop
from bywire.runtime.loop import MODE_LOG_LENGTH, Runtime
from bywire.runtime.readers import COUNTER_MISS_LIMIT
from bywire.runtime.recent_fault import FAULT_HOLD_S
from bywire.runtime.settings import RuntimeConfig
from tests.system.harness import Robot


class CreepingClock(VirtualClock):
    """Virtual time that moves on by a microsecond at every reading, as a real clock does
    between two reads: a shell that reads it once per task decides once per task."""

    def now(self) -> float:
        self._now_s += 1e-6
        return self._now_s


def _decisions(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """The instants of the loop's decisions, as they are taken."""
    decisions: list[float] = []
    original = controller.controller_step

    def counted(
        state: ControlState, inputs: ControlInputs, now: float, config: ControlConfig
    ) -> tuple[ControlState, ControlOutputs]:
        decisions.append(now)
        return original(state, inputs, now, config)

    monkeypatch.setattr(loop, "controller_step", counted)
    return decisions


def test_one_pass_reads_the_clock_once_and_decides_once_even_as_time_moves(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Row 15: the 100 Hz tasks fall due together; the robot must run what the simulator ran."""
    clock = CreepingClock()
    world = SimWorld.create(clock)
    runtime = Runtime(world.hardware, RuntimeConfig())
    decisions = _decisions(monkeypatch)
    per_pass: list[int] = []

    def passed(_now: float) -> None:
        per_pass.append(len(decisions))
        decisions.clear()

    runtime.on_cycle.append(passed)
    world.start()
    runtime.run(until_s=0.5)
    assert sum(per_pass) > 40  # the 100 Hz tasks ran
    assert max(per_pass) == 1


def test_writes_go_out_once_per_pass() -> None:
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(0.4))
    writes: list[int] = []
    dac = robot.world.dac

    def count(_now: float) -> None:
        writes.append(dac.writes)

    robot.runtime.on_cycle.append(count)
    robot.run(1.0)
    per_pass = [b - a for a, b in itertools.pairwise(writes)]
    assert max(per_pass) == 2  # throttle and regen, once each


def _on_a_tick(time_s: float) -> bool:
    return abs(time_s * 100 - round(time_s * 100)) < 1e-6


def test_a_frame_that_repeats_its_request_waits_for_the_tick_and_a_new_request_acts_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`changes_decision` in the loop: the RC frames of held sticks (every 7.7 ms) are decided on
    only at the 100 Hz ticks; the frame that carries a new pedal is decided, and written, at the
    instant it is complete."""
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.6, lambda: robot.world.rc.set_pedal(0.4))
    decisions = _decisions(monkeypatch)
    robot.run(0.8)
    held = [time_s for time_s in decisions if 0.4 <= time_s < 0.6]
    assert len(held) == 20
    assert all(_on_a_tick(time_s) for time_s in held)
    assert robot.runtime.ibus.parser.stats.frames > 100  # frames kept coming all along
    new_request = next(time_s for time_s in decisions if time_s >= 0.6 and not _on_a_tick(time_s))
    assert robot.throttle_volts(new_request) > 0.0
    assert robot.throttle_volts(new_request - 1e-9) == 0.0
    after = [time_s for time_s in decisions if new_request < time_s < 0.8]
    assert all(_on_a_tick(time_s) for time_s in after)  # the new pedal, held, repeats again


def test_a_command_message_losing_trust_is_news_even_when_no_request_changed() -> None:
    """A poll whose rejected frames make a message untrusted, beside a frame that repeats a
    request, is decided at once: CAN_UNTRUSTED stops CAN mode without waiting for the tick."""
    robot = Robot.build()
    robot.arm_rc()
    robot.run(0.5)
    runtime = robot.runtime
    assert not runtime._news()  # nothing arrived since the last decision
    frame_id = next(iter(runtime.can.states))
    runtime.can.states[frame_id] = replace(
        runtime.can.states[frame_id], window=(True,) * COUNTER_MISS_LIMIT, untrusted=True
    )
    assert runtime.can.untrusted
    assert runtime._news()


@pytest.mark.parametrize("lost_s", [1.50, 1.51, 1.52, 1.53])  # standing for longer than the
@pytest.mark.parametrize("hydrobrake_hz", [100, 25])  # standstill hold: off at the decision
def test_a_stop_decided_at_a_tick_engages_the_e_brake_at_once_whatever_the_brake_task_rate(
    hydrobrake_hz: int, lost_s: float
) -> None:
    """Found by `bywire verify` on a robot file with a 25 Hz brake task: a STOP that time alone
    reveals (here the RC link's timeout; a failing DAC too) is decided at a tick of the faster
    tasks, and the e-brake waited up to 40 ms for its own task while the enable line was
    already low. A decision writes what it changed at once, as it does for a new frame."""
    config = RuntimeConfig.from_robot(
        parse_config(f"[tasks]\nhydrobrake_rate_hz = {hydrobrake_hz}", "robot.toml")
    )
    robot = Robot.build(config)
    robot.arm_rc()
    robot.at(lost_s, robot.world.rc.link_lost)
    robot.run(lost_s + 0.3)
    disabled_s = robot.first_time(lost_s, lambda t: not robot.level("motors_enable", t))
    braked_s = robot.first_time(lost_s, lambda t: not robot.level("ebrake_release", t))
    assert disabled_s is not None
    assert _on_a_tick(disabled_s)  # decided by the timeout, at a tick, not by a frame
    assert lost_s < disabled_s <= lost_s + config.control.rc_timeout_s + 0.01
    assert braked_s == disabled_s


def test_nothing_in_the_running_controller_grows_with_mode_changes() -> None:
    """Row 13: the mode log was a list; a flapping switch grew it without bound."""
    robot = Robot.build(replace(RuntimeConfig()))
    rc = robot.world.rc
    robot.arm_rc()
    for index in range(400):
        at_s = 0.4 + index * 0.1
        robot.at(at_s, lambda: rc.set_mode(ControlMode.STOP))
        robot.at(at_s + 0.05, lambda: rc.set_mode(ControlMode.RC))
    robot.run(0.4 + 400 * 0.1)
    assert len(robot.runtime.mode_log) == MODE_LOG_LENGTH
    assert robot.runtime.mode_log[-1][1] is ControlMode.RC


def test_the_steering_report_carries_the_encoders_angle() -> None:
    """Row 14: with an encoder fitted the report said 'not measured' every time."""
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_steering(0.5))
    robot.at(0.3, lambda: robot.world.rc.set_gear(Gear.FORWARD))
    robot.run(1.5)
    report = robot.world.hlc.latest(SteeringReport)
    assert isinstance(report, SteeringReport)
    assert report.measured_valid
    assert report.measured_norm == pytest.approx(robot.world.vehicle.state.steering_norm, abs=0.02)
    assert report.measured_norm == pytest.approx(0.5, abs=0.02)


def test_without_an_encoder_the_report_says_so() -> None:
    robot = Robot.build()
    robot.world.steering_encoder.failed = True
    robot.run(0.5)
    report = robot.world.hlc.latest(SteeringReport)
    assert isinstance(report, SteeringReport)
    assert (report.measured_valid, report.measured_norm) == (False, 0.0)


def test_the_wheel_speed_report_carries_a_measured_speed_as_valid() -> None:
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_gear(Gear.FORWARD))
    robot.at(0.3, lambda: robot.world.rc.set_throttle(0.3))
    robot.run(2.0)
    report = robot.world.hlc.latest(WheelSpeedReport)
    assert isinstance(report, WheelSpeedReport)
    assert report.measured_valid
    true_speed = robot.world.vehicle.state.speed_mps
    assert true_speed > 0.1
    assert (report.left_mps + report.right_mps) / 2 == pytest.approx(true_speed, abs=0.05)


def test_a_wheel_sensor_that_gives_no_reading_is_reported_unmeasured_not_standstill() -> None:
    """Row 60: without a reading the report said 0 m/s, which a computer takes for standstill."""
    robot = Robot.build()
    robot.world.wheel_sensor.fail()
    robot.run(0.5)
    report = robot.world.hlc.latest(WheelSpeedReport)
    assert isinstance(report, WheelSpeedReport)
    assert (report.measured_valid, report.left_mps, report.right_mps) == (False, 0.0, 0.0)


@pytest.mark.parametrize("freeze", [True, False])
def test_the_loop_freezes_start_ups_objects_only_if_the_robot_file_says_so(freeze: bool) -> None:
    # `[realtime] gc_freeze = false` was read and documented, and the loop froze regardless.
    robot = default_sim_config()
    robot = replace(robot, realtime=replace(robot.realtime, gc_freeze=freeze))
    clock = VirtualClock()
    world = SimWorld.create(clock)
    runtime = Runtime(world.hardware, RuntimeConfig.from_robot(robot))
    gc.unfreeze()
    try:
        runtime.run(until_s=0.05)
        assert (gc.get_freeze_count() > 0) is freeze
    finally:
        gc.unfreeze()


# --- the ports' own failures: reported while they last, never acted on --------------------------


class Flags:
    """The loop's decided flags and the computer's latest ErrorReport, after every pass."""

    def __init__(self, robot: Robot) -> None:
        self.decided: list[tuple[float, ErrorFlag]] = []
        self.reported: list[tuple[float, ErrorFlag]] = []
        self._robot = robot
        robot.runtime.on_cycle.append(self._observe)

    def _observe(self, now: float) -> None:
        outputs, report = self._robot.runtime.outputs, self._robot.world.hlc.latest(ErrorReport)
        if outputs is not None:
            self.decided.append((now, ErrorFlag(outputs.error_flags)))
        if isinstance(report, ErrorReport):
            self.reported.append((now, report.flags))

    def up(self, flag: ErrorFlag, first_s: float, last_s: float) -> bool:
        """The flag in every decision from `first_s` to `last_s`."""
        between = [flags for now, flags in self.decided if first_s <= now <= last_s]
        return bool(between) and all(flag in flags for flags in between)

    def times(self, flag: ErrorFlag) -> list[float]:
        return [now for now, flags in self.decided if flag in flags]


def _rc_driving(fault: Callable[[Robot], None] | None = None) -> tuple[Robot, Flags]:
    """Armed into RC, 0.5 throttle from 0.3 s, for 3 s; `fault` schedules a fault on it."""
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(0.5))
    if fault is not None:
        fault(robot)
    flags = Flags(robot)
    robot.run(3.0)
    return robot, flags


def _bus_off(robot: Robot) -> None:
    port = robot.world.controller_can
    robot.at(1.0, port.enter_bus_off)
    robot.at(2.0, port.recover_bus_off)


def _rc_port_gone(robot: Robot) -> None:
    robot.at(1.0, robot.world.uart.fail)
    robot.at(2.0, robot.world.uart.restore)


def _drive_histories(robot: Robot) -> dict[str, object]:
    """Every output that moves the robot, as it changed."""
    world = robot.world
    lines = ("motors_enable", "motors_forward", "motors_reverse", "ebrake_release")
    return {
        **{name: world.gpio[name].history for name in lines},
        "dac": world.dac.history,
        "steering": world.pwm.steering.history,
        "hydrobrake": world.pwm.hydrobrake.history,
    }


def test_a_can_controller_bus_off_raises_can_bus_off_while_it_lasts_and_decides_nothing() -> None:
    plain, plain_flags = _rc_driving()
    robot, flags = _rc_driving(_bus_off)
    assert plain_flags.times(ErrorFlag.CAN_BUS_OFF) == []
    assert flags.up(ErrorFlag.CAN_BUS_OFF, 1.0 + 0.011, 2.0 + FAULT_HOLD_S - 0.01)
    assert max(flags.times(ErrorFlag.CAN_BUS_OFF)) <= 2.0 + FAULT_HOLD_S
    # The error LED says so on the robot; the computer learns it once the bus is back.
    assert robot.level("error_led", 1.5)
    assert not plain.level("error_led", 1.5)
    assert not robot.level("error_led", 2.9)
    assert any(ErrorFlag.CAN_BUS_OFF in seen for now, seen in flags.reported if now > 2.0)
    # A report, not a decision: RC drives on exactly as without the fault.
    assert _drive_histories(robot) == _drive_histories(plain)
    assert robot.runtime.outputs is not None
    assert robot.runtime.outputs.mode is ControlMode.RC


def test_an_rc_port_that_is_gone_raises_ibus_port_failed_and_the_rc_timeout_stops_the_robot() -> (
    None
):
    robot, flags = _rc_driving(_rc_port_gone)
    assert flags.times(ErrorFlag.IBUS_PORT_FAILED)[0] == pytest.approx(1.0, abs=0.011)
    assert flags.up(ErrorFlag.IBUS_PORT_FAILED, 1.011, 2.0 + FAULT_HOLD_S - 0.01)
    assert max(flags.times(ErrorFlag.IBUS_PORT_FAILED)) <= 2.0 + FAULT_HOLD_S
    # The RC timeout, not the flag, stops the robot: as a receiver that falls silent does.
    rc_timeout_s = RuntimeConfig().control.rc_timeout_s
    assert robot.level("motors_enable", 1.0)
    assert robot.safe_at(1.0 + rc_timeout_s + 0.02)
    assert not robot.safe_at(1.0 + rc_timeout_s - 0.01)
    # The link is back, the STOP it caused stays latched and named (RC_TIMEOUT) until re-armed.
    assert flags.up(ErrorFlag.RC_TIMEOUT, 2.6, 3.0)
    assert robot.runtime.outputs is not None
    assert robot.runtime.outputs.mode is ControlMode.STOP
