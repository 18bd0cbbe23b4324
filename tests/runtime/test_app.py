"""The runtime's pass: one clock reading, one decision, at most one write per output; bounded
memory; reports that carry what the sensors measured (issue 10, rows 13-15)."""

from __future__ import annotations

import gc
import itertools
from dataclasses import replace

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.control import controller
from bywire.control.controller import ControlConfig, ControlInputs, ControlOutputs, ControlState
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, Gear, SteeringReport
from bywire.runtime import app
from bywire.runtime.app import MODE_LOG_LENGTH, Runtime
from bywire.runtime.readers import COUNTER_MISS_LIMIT
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

    monkeypatch.setattr(app, "controller_step", counted)
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


@pytest.mark.parametrize("lost_s", [0.50, 0.51, 0.52, 0.53])
@pytest.mark.parametrize("hydrobrake_hz", [100, 25])
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
    robot.run(0.8)
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
