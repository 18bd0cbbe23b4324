"""Model field values <-> raw DBC signal values: scale, offset and range, exact for 64-bit values.

A field whose type is an ``enum.IntFlag`` (the ErrorReport's ``flags``) has no signal of its
own: each member of the flag type is a 1-bit signal named as the member. Bits that name no
member are not sent, and reserved bits of a received frame are ignored.

Ranges are checked on raw integers, computed once from the DBC's physical [min|max] and never
wider than the signal's bits hold, so no float comparison decides whether a frame is accepted.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import fields
from typing import TYPE_CHECKING, Any, cast, get_type_hints

from cantools.database.can import Message, Signal

from bywire.command_table import COMMAND_TYPES
from bywire.errors import FrameError
from bywire.model import REPORT_TYPES, Command, Report

if TYPE_CHECKING:
    from _typeshed import DataclassInstance


def _field_types(kind: type[Command] | type[Report]) -> dict[str, Any]:
    """Each field's annotated type, in the fields' order (not the base `Command`'s names)."""
    hints = get_type_hints(kind)
    # cast: a Command is a dataclass, which `Command` cannot tell mypy (model.command_fields)
    kind_fields = fields(cast("type[DataclassInstance]", kind))
    return {field.name: hints[field.name] for field in kind_fields}


# Field name -> annotated type, resolved once (the model uses postponed annotations).
_FIELD_TYPES: dict[type[Command] | type[Report], dict[str, Any]] = {
    kind: _field_types(kind) for kind in (*COMMAND_TYPES, *REPORT_TYPES)
}


def raw_bounds(signal: Signal) -> tuple[int, int]:
    """The raw values the signal's [min|max] allow, clipped to what its bits can hold.

    Computed once per signal: every report and command frame asks, 450 times a second.
    """
    cached = _BOUNDS.get(id(signal))
    if cached is None or cached[0] is not signal:
        cached = _BOUNDS[id(signal)] = (signal, _compute_bounds(signal))
    return cached[1]


_BOUNDS: dict[int, tuple[Signal, tuple[int, int]]] = {}


def _compute_bounds(signal: Signal) -> tuple[int, int]:
    low, high = _bit_bounds(signal)
    if signal.minimum is not None:
        low = max(low, to_raw(signal, signal.minimum))
    if signal.maximum is not None:
        high = min(high, to_raw(signal, signal.maximum))
    return low, high


def _bit_bounds(signal: Signal) -> tuple[int, int]:
    if signal.is_signed:
        half = 1 << (signal.length - 1)
        return -half, half - 1
    return 0, (1 << signal.length) - 1


def to_raw(signal: Signal, value: float) -> int:
    """The raw value nearest to a physical one; FrameError for NaN or infinity.

    Ties round away from zero and the arithmetic is C's ``round((value - offset) / scale)``, so
    the generated C encoders (``bywire dbc codegen`` uses cantools' ``use_round``) agree with
    this one bit for bit.
    """
    if isinstance(value, int) and signal.scale == 1 and signal.offset == 0:
        return int(value)  # exact: a float detour would round 64-bit values
    if not math.isfinite(value):
        raise FrameError(f"signal {signal.name}: {value} cannot be encoded")
    return _round_half_away((value - signal.offset) / signal.scale)


def _round_half_away(steps: float) -> int:
    """C's ``round()``, exactly: ``x - floor(x)`` is exact in binary floating point."""
    whole = math.floor(abs(steps))
    rounded = whole + 1 if abs(steps) - whole >= 0.5 else whole
    return -rounded if steps < 0 else rounded


def scaled(signal: Signal, raw: int) -> float:
    """The physical value of a raw one.

    Dividing by the whole number of steps per unit, when there is one, gives the float nearest
    the decimal value (0.1234, not 0.12340000000000001 from multiplying by 0.0001).
    """
    steps_per_unit = round(1 / signal.scale)
    if math.isclose(steps_per_unit * signal.scale, 1.0, rel_tol=1e-12):
        return raw / steps_per_unit + signal.offset
    return float(raw * signal.scale + signal.offset)


def raw_values(message: Message, value: object, saturate: bool) -> dict[str, int]:
    """Raw signal values of a model dataclass; out of range: saturated, or FrameError."""
    raw: dict[str, int] = {}
    field_types = _FIELD_TYPES[type(value)]  # type: ignore[index]
    for field in dataclasses.fields(value):  # type: ignore[arg-type]
        physical = getattr(value, field.name)
        flag_type = _flag_type(field_types[field.name])
        if flag_type is not None:
            raw |= {str(member.name): int(bool(physical & member)) for member in flag_type}
            continue
        signal = message.get_signal_by_name(field.name)
        raw[field.name] = _fit(message, signal, to_raw(signal, physical), saturate, physical)
    return raw


def _flag_type(field_type: Any) -> type[enum.IntFlag] | None:
    """The flag type of a field that is a set of flags, one signal per member; else None."""
    if isinstance(field_type, type) and issubclass(field_type, enum.IntFlag):
        return field_type
    return None


def _fit(message: Message, signal: Signal, raw: int, saturate: bool, physical: object) -> int:
    low, high = raw_bounds(signal)
    if saturate:
        return min(max(raw, low), high)
    if not low <= raw <= high:
        limits = f"[{signal.minimum}, {signal.maximum}]"
        raise FrameError(f"{message.name}.{signal.name} = {physical} is outside {limits}")
    return raw


def raw_decode(message: Message, data: bytes | bytearray) -> dict[str, int]:
    """Every signal of a frame as its raw integer (length already checked by the caller)."""
    decoded = message.decode_simple(bytes(data), decode_choices=False, scaling=False)
    return {name: _as_int(name, value) for name, value in decoded.items()}


def _as_int(name: str, value: object) -> int:
    if isinstance(value, int):
        return value
    raise FrameError(f"signal {name}: raw value {value!r} is not an integer")


def build(
    kind: type[Command] | type[Report], message: Message, raw: dict[str, int], check_range: bool
) -> Command | Report:
    """An instance of the model dataclass ``kind`` from raw values.

    Raises ValueError when ``check_range`` is set and a raw value lies outside its signal's
    range, or when an enum field's raw value names no member.
    """
    values: dict[str, Any] = {}
    for name, field_type in _FIELD_TYPES[kind].items():
        flag_type = _flag_type(field_type)
        if flag_type is not None:
            values[name] = _flags(flag_type, raw)
            continue
        signal = message.get_signal_by_name(name)
        if check_range:
            _check_range(signal, raw[name])
        values[name] = _field_value(field_type, signal, raw[name])
    return kind(**values)


def _flags(flag_type: type[enum.IntFlag], raw: dict[str, int]) -> enum.IntFlag:
    """The members whose 1-bit signal is set."""
    value = flag_type(0)
    for member in flag_type:
        if raw[str(member.name)]:
            value |= member
    return value


def _check_range(signal: Signal, raw: int) -> None:
    low, high = raw_bounds(signal)
    if not low <= raw <= high:
        raise ValueError(f"{signal.name} raw {raw} outside {low}..{high}")


def _field_value(field_type: Any, signal: Signal, raw: int) -> Any:
    if field_type is bool:
        return raw != 0
    if field_type is float:
        return scaled(signal, raw)
    if isinstance(field_type, type) and issubclass(field_type, enum.IntEnum):
        return _enum_member(field_type, signal, raw)
    if signal.scale == 1 and signal.offset == 0:
        return raw
    return round(scaled(signal, raw))


def _enum_member(kind: type[enum.IntEnum], signal: Signal, raw: int) -> enum.IntEnum:
    try:
        return kind(raw)
    except ValueError:
        raise ValueError(f"{signal.name} raw {raw} names no {kind.__name__}") from None
