"""The receive checks: one row per CAN command message, from the DBC and the robot's timeouts."""

from __future__ import annotations

from pathlib import Path

import cantools
import pytest

import bywire.protocol
from bywire.command_table import COMMAND_TYPES
from bywire.config import TimeoutsSection, parse_config
from bywire.model import ControlCommand, LightsCommand, MovementCommand
from bywire.runtime.rx_checks import MIN_PERIODS_PER_TIMEOUT, rx_check, rx_checks
from bywire.runtime.settings import RuntimeConfig

DBC_PATH = Path(bywire.protocol.__file__).with_name("albert.dbc")


def test_every_command_message_of_the_dbc_has_one_row_read_from_the_file() -> None:
    """Read with cantools directly: the rows carry the file's ids, lengths and cycle times."""
    database = cantools.database.load_file(DBC_PATH)
    assert isinstance(database, cantools.database.can.Database)
    rows = rx_checks(TimeoutsSection())
    assert [row.name for row in rows] == [kind.__name__ for kind in COMMAND_TYPES]
    for row in rows:
        message = database.get_message_by_name(row.name)
        assert message.senders == ["HLC"]
        assert row.frame_id == message.frame_id
        assert row.length_bytes == message.length
        assert message.cycle_time is not None
        assert row.period_s == pytest.approx(message.cycle_time / 1000)
        assert row.counter_modulus == 1 << message.get_signal_by_name("counter").length
        assert row.timeout_s >= MIN_PERIODS_PER_TIMEOUT * row.period_s


def test_each_row_takes_its_messages_own_timeout_from_the_configuration() -> None:
    text = (
        "[timeouts]\ncan_command_timeout_s = 0.08\n"
        "[timeouts.can_message_timeout_s]\nLightsCommand = 0.5"
    )
    rows = rx_checks(parse_config(text).timeouts)
    assert rx_check(rows, LightsCommand).timeout_s == 0.5
    assert rx_check(rows, MovementCommand).timeout_s == 0.08
    assert rx_check(rows, ControlCommand).timeout_s == 0.08


def test_the_runtime_judges_each_command_by_its_own_row() -> None:
    text = "[timeouts.can_message_timeout_s]\nControlCommand = 0.06\nLightsCommand = 0.5"
    runtime = RuntimeConfig.from_robot(parse_config(text))
    control = runtime.control
    timeouts_s = (MovementCommand, ControlCommand, LightsCommand)
    assert [control.command_timeout_s(kind) for kind in timeouts_s] == [0.1, 0.06, 0.5]
    assert runtime.rx_checks == rx_checks(parse_config(text).timeouts)


def test_a_row_reads_as_a_sentence() -> None:
    row = rx_check(rx_checks(TimeoutsSection()), MovementCommand)
    assert row.describe() == (
        "MovementCommand 0x101: 8 bytes, counter mod 16, CRC-8 in the last byte,"
        " every 20 ms, lost after 100 ms"
    )


def test_a_command_without_a_row_is_named() -> None:
    rows = [row for row in rx_checks(TimeoutsSection()) if row.kind is not LightsCommand]
    with pytest.raises(LookupError, match="LightsCommand"):
        rx_check(rows, LightsCommand)
