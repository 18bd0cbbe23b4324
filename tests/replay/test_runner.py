"""The replay runner: a recorded simulated run replays to identical outputs; a change diverges."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from bywire.config import RobotConfig, default_sim_config
from bywire.control.steering import SteeringConfig
from bywire.hal.tape.run_record import RecordedRun, read_record
from bywire.replay.recorder import SimRunRecorder
from bywire.replay.runner import replay
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun


def _record(scenario: str, duration_s: float, path: Path) -> RecordedRun:
    sim = SimRun(default_sim_config(), find_scenario(scenario), duration_s=duration_s)
    recorder = SimRunRecorder.attach(sim, path)
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
