"""The replay runner: a recorded simulated run replays to identical outputs; a change diverges."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import pytest

from bywire.config import RobotConfig, default_sim_config
from bywire.control.steering import SteeringConfig
from bywire.error_flags import ErrorFlag
from bywire.hal.tape.run_record import RecordedRun, read_record
from bywire.model import ErrorReport
from bywire.protocol import dbc
from bywire.replay.recorder import SimRunRecorder
from bywire.replay.runner import replay
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun


def _record(
    scenario: str, duration_s: float, path: Path, faults: Callable[[SimRun], None] | None = None
) -> RecordedRun:
    sim = SimRun(default_sim_config(), find_scenario(scenario), duration_s=duration_s)
    recorder = SimRunRecorder.attach(sim, path)
    if faults is not None:
        faults(sim)
    sim.run()
    recorder.write()
    return read_record(path)


def _with_servo(robot: RobotConfig, servo: SteeringConfig) -> RobotConfig:
    return dataclasses.replace(robot, steering=dataclasses.replace(robot.steering, servo=servo))


@pytest.fixture(scope="module")
def course(tmp_path_factory: pytest.TempPathFactory) -> RecordedRun:
    return _record("test-course", 5.0, tmp_path_factory.mktemp("record") / "course.jsonl")


# --- the whole loop -------------------------------------------------------------------------


def test_a_recorded_sim_run_replays_to_identical_outputs(course: RecordedRun) -> None:
    result = replay(course)
    assert result.divergence is None
    assert result.replayed == result.recorded
    names = {output.name for output in course.outputs}
    assert {"steering_pwm", "hydrobrake_pwm", "dac.0", "gpio.motors_enable"} <= names
    assert any(name.startswith("can_tx.0x20") for name in names)
    assert course.rc_bytes
    assert course.can_rx
    assert course.sensor_reads["wheel_speeds"]


def test_a_changed_steering_limit_diverges_where_the_robot_first_steers_right(
    course: RecordedRun,
) -> None:
    robot = default_sim_config()
    narrower = robot.steering.servo.max_pulse_s - 0.0001
    result = replay(
        course, _with_servo(robot, dataclasses.replace(robot.steering.servo, max_pulse_s=narrower))
    )
    divergence = result.divergence
    assert divergence is not None
    assert divergence.name == "steering_pwm"
    assert 3.5 <= divergence.time_s < 3.6  # test-course: RC steers right at 3.5 s
    assert divergence.recorded != divergence.replayed


def test_a_changed_steering_centre_diverges_at_the_first_safe_write(course: RecordedRun) -> None:
    robot = default_sim_config()
    centre = robot.steering.servo.center_pulse_s + 0.00005
    divergence = replay(
        course, _with_servo(robot, dataclasses.replace(robot.steering.servo, center_pulse_s=centre))
    ).divergence
    assert divergence is not None
    assert (divergence.time_s, divergence.name) == (0.0, "steering_pwm")
    assert divergence.replayed == pytest.approx(centre)


@pytest.mark.parametrize(
    ("scenario", "refused"), [("dac-failure", "dac"), ("can-unplugged", "can_tx")]
)
def test_refused_writes_and_sends_are_recorded_and_replayed(
    scenario: str, refused: str, tmp_path: Path
) -> None:
    record = _record(scenario, 5.0, tmp_path / "run.jsonl.gz")
    assert record.refusals.get(refused)
    assert replay(record).divergence is None


def test_a_tampered_sensor_reading_makes_the_replay_diverge(course: RecordedRun) -> None:
    reads = course.sensor_reads["wheel_speeds"]
    faster = [(n, (9.0, 9.0) if n > 200 else value) for n, value in reads]
    tampered = dataclasses.replace(
        course, sensor_reads={**course.sensor_reads, "wheel_speeds": faster}
    )
    assert replay(tampered).divergence is not None


def _ports_fail(sim: SimRun) -> None:
    """The controller's CAN controller goes bus-off for a second, then its RC port for one."""
    clock, world = sim.world.clock, sim.world
    clock.call_at(1.0, world.controller_can.enter_bus_off)
    clock.call_at(2.0, world.controller_can.recover_bus_off)
    clock.call_at(2.5, world.uart.fail)
    clock.call_at(3.5, world.uart.restore)


def test_a_run_whose_ports_fail_replays_to_the_same_reports(tmp_path: Path) -> None:
    record = _record("test-course", 5.0, tmp_path / "ports.jsonl", _ports_fail)
    assert [link.down for _, link in record.links["can"]] == [True, False]
    assert [link.down for _, link in record.links["rc_uart"]] == [True, False]
    reported = ErrorFlag(0)
    error_report = dbc.frame_id(ErrorReport)
    for output in record.outputs:
        if output.name == f"can_tx.0x{error_report:03X}":
            report = dbc.decode_report(error_report, bytes.fromhex(str(output.value)))
            assert isinstance(report, ErrorReport)
            reported |= report.flags
    assert ErrorFlag.CAN_BUS_OFF | ErrorFlag.IBUS_PORT_FAILED in reported
    assert replay(record).divergence is None
    # Without the ports' links on the record, the replay cannot say what the run reported.
    forgotten = dataclasses.replace(record, links={})
    divergence = replay(forgotten).divergence
    assert divergence is not None
    assert divergence.time_s == pytest.approx(1.0, abs=0.06)  # the first report of the bus-off
