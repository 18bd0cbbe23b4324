"""The CAN database and its typed codec: conventions, round trips, whole-frame rejection."""

from __future__ import annotations

import math
from pathlib import Path

import cantools
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.error_flags import DESCRIPTIONS, ErrorFlag
from bywire.errors import BywireError, FrameError
from bywire.hal.simulated.hlc import COMMAND_PERIOD_S
from bywire.model import (
    Command,
    ControlCommand,
    ControlMode,
    ErrorReport,
    Gear,
    LightsCommand,
    LightsReport,
    ModeReport,
    MovementCommand,
    Report,
    StatusReport,
    SteeringReport,
    WheelSpeedReport,
)
from bywire.protocol import dbc, flag_signals
from bywire.protocol.crc8 import crc8
from bywire.protocol.dbc import CommandRejected, RejectReason
from bywire.sim.verify.fault_rules import IMPOSTOR_PERIOD_S
from bywire.sim.verify.oracle.requirements import CAN_PERIOD_S
from bywire.teleop.frames import SEND_PERIOD_S

MOVEMENT_ID = 0x101

COMMANDS: list[Command] = [
    ControlCommand(remote_stop=True, re_enable=False, counter=0),
    ControlCommand(remote_stop=False, re_enable=True, counter=15),
    MovementCommand(-1.0, 0.0, 1.0, Gear.NEUTRAL, 0),
    MovementCommand(1.0, 1.0, 0.0, Gear.REVERSE, 15),
    MovementCommand(0.0001, 0.5, 0.25, Gear.FORWARD, 7),
    LightsCommand(turn_left=True, turn_right=False, hazard=True, low_beam=False, counter=9),
    LightsCommand(turn_left=False, turn_right=True, hazard=False, low_beam=True, counter=10),
]

REPORTS: list[Report] = [
    ModeReport(Gear.REVERSE, ControlMode.CAN, estop_engaged=False, stop_latched=True, armed=True),
    ModeReport(Gear.NEUTRAL, ControlMode.STOP, estop_engaged=True, stop_latched=False, armed=False),
    ErrorReport(ErrorFlag(0)),
    ErrorReport(ErrorFlag.TASK_CRASHED),
    ErrorReport(ErrorFlag.RC_TIMEOUT | ErrorFlag.NOT_ARMED),
    ErrorReport(ErrorFlag(sum(ErrorFlag))),  # every flag up
    WheelSpeedReport(left_mps=-327.68, right_mps=327.67, measured_valid=True),
    WheelSpeedReport(left_mps=1.25, right_mps=-0.01, measured_valid=True),
    WheelSpeedReport(left_mps=0.0, right_mps=0.0, measured_valid=False),
    WheelSpeedReport(left_mps=2.2, right_mps=2.2, measured_valid=True, speed_limited=True),
    SteeringReport(commanded_norm=-1.0, measured_norm=1.0, measured_valid=True),
    SteeringReport(commanded_norm=0.1234, measured_norm=-0.0007, measured_valid=False),
    LightsReport(True, False, True, False, True, False, True),
    LightsReport(False, True, False, True, False, True, False),
    StatusReport(
        uptime_s=2**24 - 1, overrun_count=65535, rc_input_age_ms=4095, can_command_age_ms=0
    ),
]


def _sealed(frame: int, body: bytes) -> bytes:
    """A command payload with a correct CRC appended, for frames the encoder refuses to make."""
    return body + bytes([crc8((frame & 0xFF, frame >> 8, *body))])


def _rejection(frame: int, data: bytes, previous: int | None = None) -> CommandRejected:
    with pytest.raises(CommandRejected) as caught:
        dbc.decode_command(frame, data, previous)
    return caught.value


# --- the database ---------------------------------------------------------------------------


def test_every_message_has_a_comment_and_a_20_ms_cycle_time() -> None:
    for message in dbc.database().messages:
        assert message.comment, message.name
        assert message.cycle_time == 20, message.name
        assert dbc.period_s(message.frame_id) == pytest.approx(0.02)


PSEUDO_UNITS = {"bool", "norm", "enum", "count", "crc8", "mac"}


def test_every_signal_has_a_real_unit_or_none_and_a_range() -> None:
    """Issue 32: pseudo-units made cantools print `0 bool`; a flag, a normalised value, an
    enumeration, a counter, a CRC or a MAC has no unit (an enumeration names its values)."""
    physical = set()
    for message in dbc.database().messages:
        for signal in message.signals:
            assert signal.unit not in PSEUDO_UNITS, f"{message.name}.{signal.name}"
            physical.add(signal.unit or "")
            if signal.name in ("gear", "control_mode"):
                assert signal.choices, f"{message.name}.{signal.name} names its values"
            assert signal.minimum is not None, signal.name
            assert signal.maximum is not None, signal.name
            assert signal.minimum < signal.maximum, signal.name
    assert physical == {"", "m/s", "ms", "s"}


def test_standard_ids_commands_before_reports_stop_first() -> None:
    assert max(dbc.command_ids()) < min(dbc.report_ids())
    assert dbc.command_ids()[0] == dbc.frame_id(ControlCommand)
    assert all(frame < 0x800 for frame in dbc.message_names())
    assert not any(message.is_extended_frame for message in dbc.database().messages)


def test_senders_commands_from_hlc_reports_from_bywire() -> None:
    assert {dbc.database().get_message_by_frame_id(f).senders[0] for f in dbc.command_ids()} == {
        "HLC"
    }
    assert {dbc.database().get_message_by_frame_id(f).senders[0] for f in dbc.report_ids()} == {
        "BYWIRE"
    }


@pytest.mark.parametrize("frame", [0x100, 0x101, 0x102])
def test_every_command_has_counter_then_crc_at_its_end(frame: int) -> None:
    message = dbc.database().get_message_by_frame_id(frame)
    counter, crc = message.get_signal_by_name("counter"), message.get_signal_by_name("crc")
    last_byte_bit = 8 * (message.length - 1)
    assert (crc.start, crc.length, crc.is_signed) == (last_byte_bit, 8, False)
    assert (counter.start, counter.length, counter.is_signed) == (last_byte_bit - 8, 4, False)


def test_network_comment_states_the_crc_parameters() -> None:
    comment = dbc.database().buses[0].comment or ""
    for fact in ("0x1D", "initial value 0xFF", "final XOR 0xFF", "0x4B", "low byte first"):
        assert fact in comment


def test_protection_layout_check_refuses_a_misplaced_crc(tmp_path: Path) -> None:
    source = (Path(dbc.__file__).parent / dbc.DBC_RESOURCE).read_text(encoding="utf-8")
    moved = source.replace("SG_ crc : 16|8@1+", "SG_ crc : 12|8@1+", 1).replace(
        "SG_ counter : 8|4@1+", "SG_ counter : 20|4@1+", 1
    )
    (tmp_path / "moved.dbc").write_text(moved, encoding="utf-8")
    loaded = dbc.load_database(tmp_path / "moved.dbc")
    with pytest.raises(dbc.DbcError, match="ControlCommand"):
        dbc._check_protection_layout(loaded.get_message_by_name("ControlCommand"))


def test_load_database_refuses_overlapping_signals(tmp_path: Path) -> None:
    path = tmp_path / "overlap.dbc"
    path.write_text(
        'VERSION ""\nBU_: A\nBO_ 1 M: 1 A\n SG_ a : 0|8@1+ (1,0) [0|1] "" A\n'
        ' SG_ b : 4|4@1+ (1,0) [0|1] "" A\n',
        encoding="utf-8",
    )
    with pytest.raises(dbc.DbcError, match=r"overlap\.dbc"):
        dbc.load_database(path)


def test_lookups_name_ids_and_refuse_unknown_ones() -> None:
    assert dbc.frame_id(MovementCommand) == MOVEMENT_ID
    assert dbc.message_name(MOVEMENT_ID) == "MovementCommand"
    assert dbc.message_names()[dbc.frame_id(WheelSpeedReport)] == "WheelSpeedReport"
    with pytest.raises(FrameError):
        dbc.period_s(0x7FF)


# --- round trips ------------------------------------------------------------------------------


@pytest.mark.parametrize("command", COMMANDS, ids=repr)
def test_command_round_trip(command: Command) -> None:
    frame, data = dbc.encode_command(command)
    assert dbc.decode_command(frame, data, previous_counter=None) == command
    assert dbc.decode_command(frame, data, previous_counter=(command.counter - 1) % 16) == command


@pytest.mark.parametrize("report", REPORTS, ids=repr)
def test_report_round_trip(report: Report) -> None:
    frame, data = dbc.encode_report(report)
    assert frame in dbc.report_ids()
    assert dbc.decode_report(frame, data) == report


def test_movement_golden_bytes_built_by_hand() -> None:
    frame, data = dbc.encode_command(MovementCommand(0.1234, 1.0, 0.0, Gear.REVERSE, 15))
    body = (1234).to_bytes(2, "little") + (10000).to_bytes(2, "little") + bytes([0, 0, 0x2F])
    assert frame == MOVEMENT_ID
    assert data == body + bytes([crc8(bytes([0x01, 0x01]) + body)])


steering = st.floats(-1.0, 1.0, allow_nan=False)
pedal = st.floats(0.0, 1.0, allow_nan=False)


@given(steering, pedal, pedal, st.sampled_from(Gear), st.integers(0, 15))
def test_movement_round_trip_within_half_a_step(
    steering_norm: float, throttle_norm: float, brake_norm: float, gear: Gear, counter: int
) -> None:
    sent = MovementCommand(steering_norm, throttle_norm, brake_norm, gear, counter)
    frame, data = dbc.encode_command(sent)
    received = dbc.decode_command(frame, data, previous_counter=(counter + 15) % 16)
    assert isinstance(received, MovementCommand)
    assert (received.gear, received.counter) == (gear, counter)
    for name in ("steering_norm", "throttle_norm", "brake_norm"):
        assert abs(getattr(received, name) - getattr(sent, name)) <= 0.00005 + 1e-12
    assert dbc.encode_command(received) == (frame, data)


def test_reports_saturate_at_the_signal_range() -> None:
    status = StatusReport(
        uptime_s=10**9, overrun_count=10**6, rc_input_age_ms=10**5, can_command_age_ms=-3
    )
    assert dbc.decode_report(*dbc.encode_report(status)) == StatusReport(2**24 - 1, 65535, 4095, 0)
    speeds = dbc.decode_report(*dbc.encode_report(WheelSpeedReport(1000.0, -1000.0, True)))
    assert speeds == WheelSpeedReport(327.67, -327.68, True)


# --- the ErrorReport: one 1-bit signal per ErrorFlag --------------------------------------------

ALBERT_DBC = Path(dbc.__file__).with_name("albert.dbc")


def test_error_report_signals_are_the_error_flags_exactly() -> None:
    message = dbc.database().get_message_by_name("ErrorReport")
    signals = [(signal.name, signal.start, signal.length) for signal in message.signals]
    flags = [(str(flag.name), int(flag).bit_length() - 1, 1) for flag in ErrorFlag]
    assert sorted(signals, key=lambda s: s[1]) == sorted(flags, key=lambda f: f[1])
    assert [signal.comment for signal in message.signals] == [
        DESCRIPTIONS[ErrorFlag[signal.name]] for signal in message.signals
    ]


def test_albert_dbc_holds_the_error_report_rendered_from_error_flag() -> None:
    text = ALBERT_DBC.read_text(encoding="utf-8")
    assert flag_signals.message_block() in text
    assert flag_signals.comment_lines() in text
    assert dbc.frame_id(ErrorReport) == flag_signals.ERROR_REPORT_ID


def test_every_error_flag_is_one_bit_and_has_a_description() -> None:
    for flag in ErrorFlag:
        assert int(flag).bit_count() == 1, flag
        assert DESCRIPTIONS[flag].endswith("."), flag
    assert set(DESCRIPTIONS) == set(ErrorFlag)


def test_cantools_decodes_an_error_report_to_named_flags() -> None:
    """Any DBC tool shows names: cantools, loading the file itself, no bywire code decoding."""
    frame, data = dbc.encode_report(ErrorReport(ErrorFlag.RC_TIMEOUT | ErrorFlag.REMOTE_STOP))
    database = cantools.database.load_file(ALBERT_DBC)
    assert isinstance(database, cantools.database.can.Database)
    decoded = database.decode_message(frame, data)
    assert isinstance(decoded, dict)  # a plain message, not a container
    assert {name for name, value in decoded.items() if value} == {"RC_TIMEOUT", "REMOTE_STOP"}
    assert len(decoded) == len(ErrorFlag)
    assert data == ((1 << 8) | (1 << 19)).to_bytes(8, "little")


def test_error_report_reserved_bits_are_ignored_and_never_sent() -> None:
    frame = dbc.frame_id(ErrorReport)
    received = dbc.decode_report(frame, ((1 << 63) | (1 << 40) | 1).to_bytes(8, "little"))
    assert received == ErrorReport(ErrorFlag.TASK_CRASHED)
    _, data = dbc.encode_report(ErrorReport(ErrorFlag((1 << 63) | (1 << 2))))
    assert data == (1 << 2).to_bytes(8, "little")


def test_report_nan_is_a_frame_error() -> None:
    with pytest.raises(FrameError):
        dbc.encode_report(WheelSpeedReport(math.nan, 0.0, True))


@pytest.mark.parametrize(
    "command",
    [
        MovementCommand(1.01, 0.0, 0.0, Gear.NEUTRAL, 0),
        MovementCommand(0.0, -0.01, 0.0, Gear.NEUTRAL, 0),
        MovementCommand(0.0, 0.0, math.nan, Gear.NEUTRAL, 0),
        MovementCommand(0.0, 0.0, 0.0, Gear.NEUTRAL, 16),
        ControlCommand(remote_stop=True, re_enable=False, counter=-1),
    ],
    ids=repr,
)
def test_encoder_refuses_out_of_range_commands(command: Command) -> None:
    with pytest.raises(FrameError):
        dbc.encode_command(command)


def test_decode_report_refuses_commands_unknown_ids_lengths_and_enums() -> None:
    frame, data = dbc.encode_report(ModeReport(Gear.FORWARD, ControlMode.RC, False, False, True))
    for bad_frame, bad_data in [(MOVEMENT_ID, bytes(8)), (0x7FF, data), (frame, data + b"\0")]:
        with pytest.raises(FrameError):
            dbc.decode_report(bad_frame, bad_data)
    with pytest.raises(FrameError, match="gear"):
        dbc.decode_report(frame, bytes([0x03, 0x00]))


# --- rejection: the whole frame or nothing ----------------------------------------------------


def test_rejection_is_a_frame_error_and_a_bywire_error() -> None:
    rejection = _rejection(0x7FF, bytes(8))
    assert isinstance(rejection, FrameError)
    assert isinstance(rejection, BywireError)
    assert (rejection.reason, rejection.frame_id, rejection.counter) == (
        RejectReason.UNKNOWN_ID,
        0x7FF,
        None,
    )


@pytest.mark.parametrize("frame", [0x000, 0x0FF, 0x1FF, 0x200, 0x205, 0x7FF])
def test_unknown_and_report_ids_are_not_commands(frame: int) -> None:
    assert _rejection(frame, bytes(8)).reason is RejectReason.UNKNOWN_ID


@pytest.mark.parametrize("command", COMMANDS[::2], ids=repr)
def test_wrong_length_shorter_longer_empty(command: Command) -> None:
    frame, data = dbc.encode_command(command)
    for wrong in (data[:-1], data + b"\x00", b""):
        rejection = _rejection(frame, wrong)
        assert (rejection.reason, rejection.counter) == (RejectReason.LENGTH, None)


@pytest.mark.parametrize("command", COMMANDS, ids=repr)
def test_any_flipped_byte_fails_the_crc(command: Command) -> None:
    frame, data = dbc.encode_command(command)
    for index in range(len(data)):
        corrupted = bytearray(data)
        corrupted[index] ^= 0xFF
        rejection = _rejection(frame, bytes(corrupted))
        assert (rejection.reason, rejection.counter) == (RejectReason.CHECKSUM, None), index


def test_frame_under_another_id_of_the_same_length_fails_the_crc() -> None:
    _frame, data = dbc.encode_command(ControlCommand(remote_stop=False, re_enable=True, counter=1))
    rejection = _rejection(dbc.frame_id(LightsCommand), data)
    assert rejection.reason is RejectReason.CHECKSUM


@pytest.mark.parametrize(("previous", "received"), [(4, 4), (4, 6), (4, 3), (15, 15), (15, 1)])
def test_repeated_or_skipped_counter_is_rejected_and_reported(previous: int, received: int) -> None:
    frame, data = dbc.encode_command(MovementCommand(0.5, 0.5, 0.0, Gear.FORWARD, received))
    rejection = _rejection(frame, data, previous)
    assert (rejection.reason, rejection.counter) == (RejectReason.COUNTER, received)


def test_decoders_take_bytearray_as_python_can_delivers_it() -> None:
    frame, data = dbc.encode_command(COMMANDS[2])
    assert dbc.decode_command(frame, bytearray(data), None) == COMMANDS[2]
    frame, data = dbc.encode_report(REPORTS[0])
    assert dbc.decode_report(frame, bytearray(data)) == REPORTS[0]


def test_counter_wraps_from_15_to_0() -> None:
    frame, data = dbc.encode_command(LightsCommand(True, False, False, False, counter=0))
    assert dbc.decode_command(frame, data, previous_counter=15).counter == 0


def test_unknown_previous_counter_accepts_any_counter() -> None:
    for counter in range(16):
        frame, data = dbc.encode_command(ControlCommand(False, False, counter))
        assert dbc.decode_command(frame, data, previous_counter=None).counter == counter


@pytest.mark.parametrize(
    "body",
    [
        (10001).to_bytes(2, "little", signed=True) + bytes(4) + bytes([0x05]),  # steering > 1
        (-10001).to_bytes(2, "little", signed=True) + bytes(4) + bytes([0x05]),  # steering < -1
        bytes(2) + (10001).to_bytes(2, "little") + bytes(2) + bytes([0x05]),  # throttle > 1
        bytes(4) + (0xFFFF).to_bytes(2, "little") + bytes([0x05]),  # brake > 1
        bytes(6) + bytes([0x35]),  # gear 3 (undefined), counter 5
    ],
)
def test_out_of_range_values_reject_the_whole_frame(body: bytes) -> None:
    rejection = _rejection(MOVEMENT_ID, _sealed(MOVEMENT_ID, body), previous=4)
    assert (rejection.reason, rejection.counter) == (RejectReason.RANGE, 5)


def test_checks_run_in_order_id_length_crc_counter_range() -> None:
    frame, data = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.NEUTRAL, 5))
    bad_range_and_counter = _sealed(MOVEMENT_ID, bytes(6) + bytes([0x35]))
    assert _rejection(0x7FF, data[:3]).reason is RejectReason.UNKNOWN_ID
    assert _rejection(frame, data[:3], previous=9).reason is RejectReason.LENGTH
    assert (
        _rejection(frame, data[:-1] + bytes([data[-1] ^ 0xFF]), previous=9).reason
        is RejectReason.CHECKSUM
    )
    assert _rejection(frame, bad_range_and_counter, previous=9).reason is RejectReason.COUNTER


def test_the_commands_period_is_the_dbc_s_and_every_sender_keeps_it() -> None:
    periods = {dbc.period_s(frame) for frame in dbc.command_ids()}
    assert periods == {dbc.command_period_s()} == {0.020}  # albert.dbc: GenMsgCycleTime 20
    assert COMMAND_PERIOD_S == SEND_PERIOD_S == IMPOSTOR_PERIOD_S == CAN_PERIOD_S == 0.020
