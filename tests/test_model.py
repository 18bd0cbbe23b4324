"""The model mirrors the DBC: enum values are its value tables, fields are its signals."""

from __future__ import annotations

import dataclasses
import enum
from typing import Any, cast, get_type_hints

import pytest

from bywire.command_table import COMMAND_TYPES
from bywire.model import (
    REPORT_TYPES,
    Command,
    ControlCommand,
    ControlMode,
    Gear,
    LightsCommand,
    MovementCommand,
    WheelSpeedReport,
    command_fields,
    same_request,
    with_counter,
)
from bywire.protocol.dbc import database


def _choices(message_name: str, signal_name: str) -> dict[int, str]:
    signal = database().get_message_by_name(message_name).get_signal_by_name(signal_name)
    return {int(value): str(name) for value, name in (signal.choices or {}).items()}


@pytest.mark.parametrize("message_name", ["MovementCommand", "ModeReport"])
def test_gear_values_are_the_dbc_value_table(message_name: str) -> None:
    assert _choices(message_name, "gear") == {gear.value: gear.name for gear in Gear}


def test_control_mode_values_are_the_dbc_value_table() -> None:
    assert _choices("ModeReport", "control_mode") == {mode.value: mode.name for mode in ControlMode}


def test_stop_is_zero_so_a_zeroed_report_reads_as_stop() -> None:
    assert ControlMode(0) is ControlMode.STOP


@pytest.mark.parametrize("kind", COMMAND_TYPES + REPORT_TYPES, ids=lambda kind: kind.__name__)
def test_fields_are_exactly_the_dbc_signals(kind: type) -> None:
    signal_names = {signal.name for signal in database().get_message_by_name(kind.__name__).signals}
    field_names: set[str] = set()
    for name, field_type in get_type_hints(kind).items():
        if isinstance(field_type, type) and issubclass(field_type, enum.IntFlag):
            field_names |= {str(member.name) for member in field_type}  # one signal per flag
        else:
            field_names.add(name)
    # The CRC is the codec's business; every other signal is a field (or a flag of one) and
    # vice versa.
    assert field_names == signal_names - {"crc"}


def test_commands_carry_a_counter_and_reports_do_not() -> None:
    assert all("counter" in {f.name for f in command_fields(kind)} for kind in COMMAND_TYPES)
    assert not any("counter" in {f.name for f in dataclasses.fields(k)} for k in REPORT_TYPES)


def test_messages_are_frozen_values() -> None:
    command = MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, counter=3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        command.counter = 4  # type: ignore[misc]  # what mypy refuses must also fail at run time
    assert command == MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, 3)
    assert len({WheelSpeedReport(1.0, 1.0, True), WheelSpeedReport(1.0, 1.0, True)}) == 1


COMMANDS: list[Command] = [
    MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, counter=3),
    LightsCommand(turn_left=True, turn_right=False, hazard=False, low_beam=True, counter=3),
    ControlCommand(remote_stop=False, re_enable=True, counter=3),
]


@pytest.mark.parametrize("command", COMMANDS, ids=lambda command: type(command).__name__)
def test_a_request_is_the_same_whatever_its_counter_and_differs_in_any_other_field(
    command: Command,
) -> None:
    assert same_request(command, with_counter(command, 4))
    for field in command_fields(type(command)):
        if field.name == "counter":
            continue
        was = getattr(command, field.name)
        other = (
            (not was) if isinstance(was, bool) else (Gear.REVERSE if was is Gear.FORWARD else 0.5)
        )
        changes: dict[str, Any] = {field.name: other}
        changed = dataclasses.replace(cast(Any, command), **changes)
        assert not same_request(command, changed), field.name
    assert not any(
        same_request(command, kind) for kind in COMMANDS if type(kind) is not type(command)
    )
