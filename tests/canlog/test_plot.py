"""CAN log decoding and its plot: signals by name, what is skipped, refusals, a drawn PNG."""

from __future__ import annotations

from pathlib import Path

import can
import pytest

from bywire.canlog.plot import (
    choose_signals,
    error_flags_seen,
    error_flags_up,
    is_albert_log,
    write_log_plot,
)
from bywire.canlog.read import decode_messages, read_can_log, read_messages
from bywire.error_flags import ErrorFlag
from bywire.errors import ConfigError
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, MovementCommand
from bywire.plot_page import DPI, SIZE_IN
from bywire.protocol import dbc
from tests.canlog import tesla_drive

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _message(time_s: float, frame_id: int, data: bytes) -> can.Message:
    return can.Message(timestamp=time_s, arbitration_id=frame_id, data=data, is_extended_id=False)


def _frames() -> list[can.Message]:
    movement = dbc.encode_command(MovementCommand(0.25, 0.5, 0.0, Gear.FORWARD, 3))
    mode = dbc.encode_report(ModeReport(Gear.FORWARD, ControlMode.CAN, False, False, True))
    flags = dbc.encode_report(ErrorReport(ErrorFlag.TASK_CRASHED | ErrorFlag.NOT_ARMED))
    return [
        _message(100.0, *movement),
        _message(100.02, *mode),
        _message(100.03, *flags),
        _message(100.04, 0x300, bytes(8)),  # another node's traffic
        _message(100.05, mode[0], b"\x01"),  # too short for ModeReport
    ]


def test_every_known_frame_becomes_signals_in_seconds_from_the_first_frame() -> None:
    log = decode_messages(_frames(), dbc.database())
    assert log.signal("MovementCommand.steering_norm").values == (0.25,)
    assert log.signal("ModeReport.control_mode").times_s == pytest.approx((0.02,))
    assert log.signal("ModeReport.control_mode").values == (ControlMode.CAN.value,)
    assert log.signal("ErrorReport.NOT_ARMED").values == (1,)
    assert log.signal("ErrorReport.RC_TIMEOUT").values == (0,)
    assert (log.frames, log.unknown_frames, log.undecodable_frames) == (5, 1, 1)
    assert log.duration_s == pytest.approx(0.05)
    assert log.signal("NoSuch.signal").values == ()


def test_error_flags_are_counted_and_named_from_their_one_bit_signals() -> None:
    reports = [
        ErrorReport(ErrorFlag(0)),
        ErrorReport(ErrorFlag.RC_TIMEOUT | ErrorFlag.REMOTE_STOP),
        ErrorReport(ErrorFlag.REMOTE_STOP),
    ]
    messages = [_message(index * 0.02, *dbc.encode_report(r)) for index, r in enumerate(reports)]
    log = decode_messages(messages, dbc.database())
    assert error_flags_up(log).values == (0, 2, 1)
    assert error_flags_up(log).times_s == pytest.approx((0.0, 0.02, 0.04))
    assert error_flags_seen(log) == ["RC_TIMEOUT", "REMOTE_STOP"]


def test_a_decoded_log_draws_a_png_with_content(tmp_path: Path) -> None:
    path = tmp_path / "frames.png"
    write_log_plot(decode_messages(_frames(), dbc.database()), path, "five frames")
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    size = (int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big"))
    assert size == (round(SIZE_IN[0] * DPI), round(SIZE_IN[1] * DPI))


@pytest.mark.parametrize("name", ["run.jpg", "run.PNG.txt", "run"])
def test_only_png_is_written(name: str, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"suffix must be \.png"):
        write_log_plot(decode_messages(_frames(), dbc.database()), tmp_path / name, "")


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("run.xyz", b"", r"suffix must be one of \.blf, \.asc, \.trc, \.mf4, \.csv"),
        ("missing.blf", None, "no such CAN log"),
        ("garbage.blf", b"garbage\x00\x01", r"not a readable \.blf CAN log"),
        ("garbage.log", b"not a candump log\n", r"line 1 is not a CAN frame of candump"),
    ],
)
def test_a_file_that_is_no_can_log_is_refused_in_one_line(
    name: str, content: bytes | None, message: str, tmp_path: Path
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ConfigError, match=message) as raised:
        read_messages(path)
    assert "\n" not in str(raised.value)


def test_a_log_without_a_single_dbc_frame_has_nothing_to_plot(tmp_path: Path) -> None:
    path = tmp_path / "other.log"
    with can.CanutilsLogWriter(path) as writer:
        writer.on_message_received(_message(1.0, 0x300, bytes(8)))
    with pytest.raises(ConfigError, match="nothing to plot: 1 frames"):
        read_can_log(path, dbc.database())


def test_the_default_choice_for_a_real_car_groups_by_unit_and_skips_counters() -> None:
    log = decode_messages(tesla_drive.frames(), tesla_drive.database())
    assert not is_albert_log(log)
    choice = choose_signals(log, tesla_drive.database(), [])
    names = dict(choice.signals)
    assert names["DI_speed.DI_vehicleSpeed"] == "kph"
    assert names["SCCM_steeringAngleSensor.SCCM_steeringAngle"] == "deg"
    assert names["ESP_wheelSpeeds.ESP_wheelSpeedFrL"] == "km/h"
    assert not [name for name in names if "Counter" in name or "Checksum" in name]
    assert len(choice.signals) <= 12
    assert len(set(names.values())) <= 6
    assert choice.defaulted


def test_globs_without_a_message_match_any_message() -> None:
    log = decode_messages(tesla_drive.frames(), tesla_drive.database())
    choice = choose_signals(log, tesla_drive.database(), ["ESP_wheelSpeedFr?"])
    assert [name for name, _ in choice.signals] == [
        "ESP_wheelSpeeds.ESP_wheelSpeedFrL",
        "ESP_wheelSpeeds.ESP_wheelSpeedFrR",
    ]
    with pytest.raises(ConfigError, match="none of the 1 signals chosen with --signal"):
        choose_signals(log, tesla_drive.database(), ["DAS_control.DAS_setSpeed"])
