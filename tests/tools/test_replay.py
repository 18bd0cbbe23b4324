"""Run records and replay: the format round-trips, ports tape and replay, divergences are named."""

from __future__ import annotations

import dataclasses
import gzip
import json
from pathlib import Path

import pytest

from bywire.config import RobotConfig, default_sim_config
from bywire.control.steering import SteeringConfig
from bywire.errors import ConfigError, HardwareError
from bywire.hal.ports import CanFrame
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.gpio_pwm import SimPwmChannel
from bywire.protocol import dac6574
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from bywire.tools.divergence import dac_volts, first_divergence
from bywire.tools.port_tape import Tape, TapedCanPort, TapedPwm, TapedSensor
from bywire.tools.replay import (
    ReplayByteStream,
    ReplayCanPort,
    ReplayDac,
    ReplayWheelSpeeds,
    replay,
)
from bywire.tools.run_record import (
    Output,
    RecordedRun,
    RecordHeader,
    read_record,
    write_record,
)
from bywire.tools.sim_record import SimRunRecorder

HEADER = RecordHeader("tiny", 0.0, 1.0, {"steering": 0.02, "hydrobrake": 0.001}, (), "")


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


# --- the format -----------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["run.jsonl", "run.jsonl.gz"])
def test_the_record_round_trips_every_value_exactly(name: str, tmp_path: Path) -> None:
    events = [
        {"t": 0.1 + 0.2, "kind": "rc_bytes", "hex": "2040"},
        {"t": 0.5, "kind": "can_rx", "frames": [[0x101, "00ff", 0.49]]},
        {"t": 0.5, "kind": "sensor", "name": "wheel_speeds", "read": 3, "value": (0.1, -0.3)},
        {"t": 0.6, "kind": "refused", "name": "dac", "call": 7},
        {"t": 0.7, "kind": "out", "name": "steering_pwm", "value": 0.0015000000000000002},
        {"t": 0.7, "kind": "out", "name": "gpio.low_beam", "value": True},
    ]
    assert write_record(tmp_path / name, HEADER, events) == len(events)
    run = read_record(tmp_path / name)
    assert run.header == HEADER
    assert run.rc_bytes == [(0.1 + 0.2, b"\x20\x40")]
    assert run.can_rx == [(0.5, [CanFrame(0x101, b"\x00\xff", 0.49)])]
    assert run.sensor_reads == {"wheel_speeds": [(3, (0.1, -0.3))]}
    assert run.refusals == {"dac": {7}}
    assert run.outputs == [
        Output(0.7, "steering_pwm", 0.0015000000000000002),
        Output(0.7, "gpio.low_beam", True),
    ]


def test_a_gzip_record_is_compressed(tmp_path: Path) -> None:
    write_record(tmp_path / "run.jsonl.gz", HEADER, [])
    with gzip.open(tmp_path / "run.jsonl.gz", "rt") as stream:
        assert json.loads(stream.readline())["format"] == "bywire-run-record"


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        (["{}"], "line 1: .*not a bywire-run-record"),
        (['{"format": "bywire-run-record", "version": 99}'], "line 1: .*version 99"),
        ([json.dumps(HEADER.as_json()), '{"t": 1, "kind": "teleport"}'], "line 2: .*teleport"),
        ([json.dumps(HEADER.as_json()), "", "not json"], "line 3"),
        ([], "line 1"),
    ],
)
def test_a_file_that_is_no_record_is_refused_naming_the_line(
    lines: list[str], message: str, tmp_path: Path
) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(ConfigError, match=message):
        read_record(path)


def test_a_missing_record_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such run record"):
        read_record(tmp_path / "missing.jsonl")


# --- comparison -----------------------------------------------------------------------------

A = [Output(0.0, "steering_pwm", 0.0015), Output(0.0, "gpio.x", False), Output(1.0, "gpio.x", True)]


def test_identical_histories_have_no_divergence() -> None:
    assert first_divergence(A, list(A)) is None
    assert first_divergence([], []) is None


def test_a_different_value_is_named_with_both_values() -> None:
    changed = [A[0], A[1], Output(1.0, "gpio.x", False)]
    divergence = first_divergence(A, changed)
    assert divergence is not None
    assert (divergence.time_s, divergence.name) == (1.0, "gpio.x")
    assert (divergence.recorded, divergence.replayed) == (True, False)
    assert "1.000000 s: gpio.x recorded True, replayed False" in divergence.describe()


def test_a_missing_or_extra_write_is_a_divergence_at_its_instant() -> None:
    missing = first_divergence(A, A[:2])
    assert missing is not None
    assert (missing.time_s, missing.name, missing.recorded, missing.replayed) == (
        1.0,
        "gpio.x",
        True,
        False,
    )
    early = first_divergence(A, [*A[:2], Output(0.5, "gpio.x", True), A[2]])
    assert early is not None
    assert (early.time_s, early.recorded, early.replayed) == (0.5, False, True)


def test_writes_in_another_order_at_one_instant_are_a_divergence() -> None:
    swapped = first_divergence(A, [A[1], A[0], A[2]])
    assert swapped is not None
    assert (swapped.time_s, swapped.name) == (0.0, "steering_pwm")


def test_an_output_never_written_shows_as_such() -> None:
    divergence = first_divergence([Output(0.0, "dac.0", "10")], [])
    assert divergence is not None
    assert "replayed (not written)" in divergence.describe()


# --- the ports ------------------------------------------------------------------------------


def test_taped_outputs_are_noted_on_change_and_can_frames_every_time() -> None:
    clock = VirtualClock()
    tape = Tape(clock)
    pwm = TapedPwm(SimPwmChannel(clock, 0.02), "steering_pwm", tape)
    for pulse_s in (0.0015, 0.0015, 0.0016):
        pwm.set_pulse(pulse_s)
    port = TapedCanPort(ReplayCanPort(clock, [], refused_calls={1}), tape)
    assert [port.send(CanFrame(0x200, b"\x01")) for _ in range(2)] == [True, False]
    kinds = [(e["kind"], e.get("name"), e.get("value", e.get("call"))) for e in tape.events]
    assert kinds == [
        ("out", "steering_pwm", 0.0015),
        ("out", "steering_pwm", 0.0016),
        ("out", "can_tx.0x200", "01"),
        ("out", "can_tx.0x200", "01"),
        ("refused", "can_tx", 1),
    ]


def test_a_taped_sensor_notes_the_reads_that_change_and_replays_them_in_order() -> None:
    tape = Tape(VirtualClock())
    values = iter([(0.0, 0.0), (0.0, 0.0), (1.0, 1.0), None])
    sensor = TapedSensor(lambda: next(values), "wheel_speeds", tape)
    readings = [sensor.read() for _ in range(4)]
    changes = [(e["read"], e["value"]) for e in tape.events]
    assert changes == [(0, (0.0, 0.0)), (2, (1.0, 1.0)), (3, None)]
    replayed = ReplayWheelSpeeds(changes)
    assert [replayed.read() for _ in range(4)] == readings


def test_replayed_inputs_arrive_at_their_recorded_instants() -> None:
    clock = VirtualClock()
    stream = ReplayByteStream(clock, [(0.1, b"\x20"), (0.1, b"\x40"), (0.2, b"\x01")])
    port = ReplayCanPort(clock, [(0.15, [CanFrame(0x101, b"", 0.15)])], set())
    assert stream.read_available() == b""
    clock.advance(0.1)
    assert (stream.read_available(), port.receive()) == (b"\x20\x40", [])
    clock.advance(0.1)
    assert stream.read_available() == b"\x01"
    assert port.receive() == [CanFrame(0x101, b"", 0.15)]


def test_the_replayed_dac_refuses_exactly_the_recorded_writes() -> None:
    written: list[bytes] = []

    class Device:
        def write(self, data: bytes) -> None:
            written.append(data)

    dac = ReplayDac(Device(), refused_calls={1})
    dac.write(b"a")
    with pytest.raises(HardwareError, match="as recorded"):
        dac.write(b"b")
    dac.write(b"c")
    assert written == [b"a", b"c"]


def test_a_dac_write_is_shown_in_volts_beside_its_i2c_frame() -> None:
    frame = dac6574.encode_write(0, 256).hex()
    other = dac6574.encode_write(0, 512).hex()
    divergence = first_divergence([Output(0.0, "dac.0", frame)], [Output(0.0, "dac.0", other)])
    assert divergence is not None
    text = divergence.describe()
    assert f"dac.0 recorded 1.250 V (I2C {frame}), replayed 2.500 V (I2C {other})" in text
    assert "recorded 0.625 V" in divergence.describe(dac_vref_volts=2.5)  # the robot's Vref
    assert dac_volts("not hex") is None
