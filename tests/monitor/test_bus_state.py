"""The monitor's message table as pure state: decoding, rates and ages at a given now, errors."""

from __future__ import annotations

import pytest

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, MovementCommand
from bywire.monitor.bus_state import BusModel, MessageRow
from bywire.monitor.view import cells, snapshot_table
from bywire.protocol import dbc

PERIOD_S = 0.02


def movement(counter: int, steering_norm: float = 0.25) -> tuple[int, bytes]:
    return dbc.encode_command(MovementCommand(steering_norm, 0.5, 0.0, Gear.FORWARD, counter))


def row_of(model: BusModel, frame_id: int, now_s: float) -> MessageRow:
    (row,) = [row for row in model.rows(now_s) if row.arbitration_id == frame_id]
    return row


def test_a_report_is_decoded_with_names_and_units() -> None:
    model = BusModel()
    frame_id, data = dbc.encode_report(ModeReport(Gear.REVERSE, ControlMode.CAN, True, False, True))
    model.add(frame_id, data, 10.0)
    row = row_of(model, frame_id, 10.0)
    assert row.name == "ModeReport"
    assert "gear=REVERSE" in [str(signal) for signal in row.signals]
    assert "control_mode=CAN" in [str(signal) for signal in row.signals]
    assert row.errors == 0


def test_a_command_shows_physical_values_with_units_and_hides_its_crc() -> None:
    model = BusModel()
    model.add(*movement(3), 1.0)
    shown = [str(signal) for signal in row_of(model, 0x101, 1.0).signals]
    assert "steering_norm=0.25" in shown
    assert "counter=3" in shown
    assert not any(text.startswith("crc") for text in shown)


def test_error_flags_are_shown_by_name() -> None:
    model = BusModel()
    frame_id, data = dbc.encode_report(ErrorReport(ErrorFlag.TASK_CRASHED | ErrorFlag.CAN_BUS_OFF))
    model.add(frame_id, data, 0.0)
    (shown,) = row_of(model, frame_id, 0.0).signals  # one line, not 23 one-bit signals
    assert str(shown) == "flags=TASK_CRASHED|CAN_BUS_OFF"
    model.add(*dbc.encode_report(ErrorReport(ErrorFlag(0))), 0.02)
    assert [str(s) for s in row_of(model, frame_id, 0.02).signals] == ["flags=none"]


def test_rate_and_age_follow_the_given_now() -> None:
    model = BusModel(rate_window_s=2.0)
    for tick in range(100):
        model.add(*movement(tick % 16), tick * PERIOD_S)
    last_s = 99 * PERIOD_S
    row = row_of(model, 0x101, last_s + 0.5)
    assert row.count == 100
    assert row.rate_hz == pytest.approx(50.0)
    assert row.age_s == pytest.approx(0.5)
    assert row_of(model, 0x101, last_s + 2.5).rate_hz == 0.0  # stopped: no frame in the window


def test_a_bad_crc_is_flagged_and_the_last_good_values_stay() -> None:
    model = BusModel()
    model.add(*movement(0, steering_norm=0.25), 0.0)
    frame_id, data = movement(1, steering_norm=-0.5)
    model.add(frame_id, data[:-1] + bytes([data[-1] ^ 0x01]), PERIOD_S)
    row = row_of(model, frame_id, PERIOD_S)
    assert (row.crc_errors, row.counter_errors) == (1, 0)
    assert "bad CRC" in row.last_error
    assert "steering_norm=0.25" in [str(signal) for signal in row.signals]
    # A CRC failure forgets the counter: the next good frame is not a counter error.
    model.add(*movement(2), 2 * PERIOD_S)
    assert row_of(model, frame_id, 2 * PERIOD_S).counter_errors == 0


def test_a_repeated_counter_is_flagged_and_resynchronised() -> None:
    model = BusModel()
    model.add(*movement(5), 0.0)
    model.add(*movement(5), PERIOD_S)
    model.add(*movement(6), 2 * PERIOD_S)
    row = row_of(model, 0x101, 2 * PERIOD_S)
    assert (row.crc_errors, row.counter_errors, row.count) == (0, 1, 3)
    assert "counter" in row.last_error


def test_a_short_report_is_counted_as_bad() -> None:
    model = BusModel()
    model.add(0x202, b"\x00", 0.0)
    row = row_of(model, 0x202, 0.0)
    assert (row.other_errors, row.signals) == (1, ())


def test_unknown_ids_are_listed_raw_in_id_order() -> None:
    model = BusModel()
    model.add(0x7F0, b"\xde\xad", 0.0)
    model.add(*movement(0), 0.0)
    rows = model.rows(0.0)
    assert [row.arbitration_id for row in rows] == [0x101, 0x7F0]
    assert (rows[1].name, rows[1].data, rows[1].errors) == ("", b"\xde\xad", 0)


def test_error_cells_are_highlighted_and_the_snapshot_has_every_row() -> None:
    model = BusModel()
    model.add(*movement(5), 0.0)
    model.add(*movement(5), PERIOD_S)
    model.add(0x7F0, b"\x01", 0.0)
    error_cell = cells(row_of(model, 0x101, PERIOD_S))[6]
    assert (error_cell.plain, str(error_cell.style)) == ("counter 1", "bold red")
    assert cells(row_of(model, 0x7F0, 0.0))[1].plain == "(unknown)"
    assert snapshot_table(model.rows(PERIOD_S), "bus").row_count == 2
