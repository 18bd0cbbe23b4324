"""The resolved configuration back as nested dicts and as TOML text that loads to the same tree."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import fields, is_dataclass

from bywire.config.speed_limit import WRITTEN_NONE
from bywire.config.tree import (
    ESTOP_NONE,
    TASK_LINE_SUFFIX,
    EstopSection,
    GpioLine,
    RobotConfig,
    TasksSection,
)
from bywire.control.drive import DriveConfig
from bywire.control.rc_mapping import RcMapping
from bywire.control.steering import SteeringConfig

# The control layer's own configs are written flat into their section, as in the TOML file.
FLATTENED = (SteeringConfig, DriveConfig, RcMapping)
# Fixed by the transmitter's switch layout (reverse flips them), so not configuration keys.
NOT_KEYS = frozenset(
    # fixed by the transmitter's switch layout, or safety policy that is not a tuning knob
    {"mode_positions", "gear_positions", "stop_flags", "encoder_valid_limit_norm"}
)
INLINE_MAX_KEYS = 3


def as_dict(config: RobotConfig) -> dict[str, object]:
    """Nested dicts laid out like the TOML file; unset optional keys left out."""
    return _table(config, config.gpio_chip)


def describe(config: RobotConfig) -> str:
    """Every resolved value as TOML text; `parse_config(describe(c)) == c`."""
    lines: list[str] = []
    _emit(as_dict(config), "", lines)
    return "\n".join(lines) + "\n"


def table_text(path: str, table: Mapping[str, object]) -> str:
    """One table of `as_dict`'s under its `[path]` header, written as `describe` writes it."""
    lines = [f"[{path}]"]
    _emit(table, f"{path}.", lines)
    return "\n".join(lines) + "\n"


def _table(node: object, chip: str) -> dict[str, object]:
    table: dict[str, object] = {}
    for field in fields(node):  # type: ignore[arg-type]
        value = getattr(node, field.name)
        if field.name in NOT_KEYS:
            continue
        if value is None:  # an optional key left out, or one whose None the file spells
            if WRITTEN_NONE in field.metadata:
                table[field.name] = field.metadata[WRITTEN_NONE]
            continue
        if isinstance(value, TasksSection):
            rates = {f"{name}_rate_hz": rate for name, rate in value.rates_hz}
            lines = {f"{name}{TASK_LINE_SUFFIX}": _line(line, chip) for name, line in value.lines}
            table[field.name] = rates | lines
        elif isinstance(value, EstopSection):
            line = ESTOP_NONE if value.line is None else _line(value.line, chip)
            table[field.name] = {"line": line}
        elif _pairs(value):
            table[field.name] = dict(value)
        elif isinstance(value, GpioLine):
            table[field.name] = _line(value, chip)
        elif isinstance(value, FLATTENED):
            table.update(_table(value, chip))
        elif is_dataclass(value):
            table[field.name] = _table(value, chip)
        else:
            table[field.name] = value
    return table


def _line(line: GpioLine, chip: str) -> object:
    """A line on the default chip as its name or offset, another chip's as a table."""
    return line.line if line.chip == chip else {"chip": line.chip, "line": line.line}


def _pairs(value: object) -> bool:
    """A tuple of (key, value) pairs: a TOML table (`[timeouts.can_message_timeout_s]`)."""
    if not isinstance(value, tuple) or not value:
        return False
    return all(
        isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str) for item in value
    )


def _emit(table: Mapping[str, object], path: str, lines: list[str]) -> None:
    nested = {
        key: value
        for key, value in table.items()
        if isinstance(value, Mapping) and not (path and _inline(value))
    }
    for key, value in table.items():
        if key not in nested:
            lines.append(f"{key} = {_value(key, value)}")
    for key, value in nested.items():
        lines.extend(("", f"[{path}{key}]"))
        _emit(value, f"{path}{key}.", lines)


def _inline(table: Mapping[str, object]) -> bool:
    scalars = not any(isinstance(value, Mapping) for value in table.values())
    return scalars and len(table) <= INLINE_MAX_KEYS


def _value(key: str, value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, int) and key == "address":
        return f"0x{value:02X}"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {_value(k, v)}" for k, v in value.items()) + " }"
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_value(key, item) for item in value) + "]"
    return repr(value)
