"""Value types every layer shares: enums and frozen messages whose field names carry their units.

The CAN messages mirror the CAN database (``protocol/albert.dbc``) one to one: each class is named
like its DBC message and each field like its DBC signal, so the codec needs no mapping table. The
codec (``bywire.protocol.dbc``) checks ranges; these types only describe values.

Units in names: ``_norm`` is a normalised set-point (steering −1…1, throttle and brake 0…1),
``_mps`` metres per second, ``_s`` seconds, ``_ms`` milliseconds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import Field, dataclass, fields, replace
from enum import IntEnum
from operator import attrgetter
from typing import TYPE_CHECKING, Any, TypeVar, cast

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

from bywire.error_flags import ErrorFlag


class Gear(IntEnum):
    """Driving direction; the values are the DBC's ``gear`` value table."""

    NEUTRAL = 0
    FORWARD = 1
    REVERSE = 2


class ControlMode(IntEnum):
    """Who drives, chosen on the RC transmitter; the values are the DBC's ``control_mode`` table.

    STOP is 0 so that an all-zero report, or a zero-initialised C struct, reads as the safe state.
    """

    STOP = 0
    RC = 1
    CAN = 2


# Commands: higher-level computer -> controller. Each carries its 4-bit rolling counter (0…15);
# the CRC is computed and checked by the codec and never appears here. The messages the
# controller obeys are the rows of `bywire.command_table`; a new one is a class there.


class Command:
    """Any command frame's content: every command message is a frozen dataclass deriving from
    this, with its signals as fields and its rolling counter as `counter`."""

    __slots__ = ()
    counter: int


@dataclass(frozen=True, slots=True)
class ControlCommand(Command):
    """Remote stop and re-enable request; re-enable acts on its rising edge only."""

    remote_stop: bool
    re_enable: bool
    counter: int


@dataclass(frozen=True, slots=True)
class MovementCommand(Command):
    """Movement set-points: steering −1 (left)…1 (right), throttle and brake 0…1, gear."""

    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: Gear
    counter: int


@dataclass(frozen=True, slots=True)
class LightsCommand(Command):
    """Light requests; brake, reverse and error lights follow the robot's state instead."""

    turn_left: bool
    turn_right: bool
    hazard: bool
    low_beam: bool
    counter: int


def command_fields(kind: type[Command]) -> tuple[Field[Any], ...]:
    """A command message's fields: each is a dataclass. (`Command` does not tell the type checker
    so itself: mypyc refuses the `if TYPE_CHECKING:` declaration in a class body, issue 43.)"""
    return fields(cast("type[DataclassInstance]", kind))


CommandT = TypeVar("CommandT", bound=Command)


def with_counter(command: CommandT, counter: int) -> CommandT:
    """The same command with another rolling counter (`dataclasses.replace`)."""
    return cast(CommandT, replace(cast(Any, command), counter=counter))


def request_fields(kind: type[Command]) -> tuple[str, ...]:
    """What a command can ask for, by signal name: every field but its rolling counter (which
    only the receive checks judge)."""
    return tuple(field.name for field in command_fields(kind) if field.name != "counter")


LIGHT_REQUESTS = request_fields(LightsCommand)
"""What a LightsCommand can ask for, by signal name."""
LIGHTS_OFF = LightsCommand(**dict.fromkeys(LIGHT_REQUESTS, False), counter=0)
"""Nothing requested: every request of a LightsCommand off."""


_REQUESTS: dict[type[Command], Callable[[Command], object]] = {}


def same_request(a: Command, b: Command) -> bool:
    """Whether two commands ask for the same thing: equal in every `request_fields`."""
    kind = type(a)
    if kind is not type(b):
        return False
    requests = _REQUESTS.get(kind)
    if requests is None:
        requests = _REQUESTS[kind] = attrgetter(*request_fields(kind))
    return requests(a) == requests(b)


# Reports: controller -> higher-level computer, 50 Hz. Values outside a signal's range are
# saturated by the encoder, so a runaway value never stops the reporting task.


@dataclass(frozen=True, slots=True)
class ModeReport:
    """Gear, control mode and the safety state."""

    gear: Gear
    control_mode: ControlMode
    estop_engaged: bool
    stop_latched: bool
    armed: bool


@dataclass(frozen=True, slots=True)
class ErrorReport:
    """The error flags that are up; none means no error. On the bus: one 1-bit signal per flag."""

    flags: ErrorFlag


@dataclass(frozen=True, slots=True)
class WheelSpeedReport:
    """Wheel speeds, positive forward (int16, 0.01 m/s per bit, as in the thesis' Figure 26);
    they mean nothing unless ``measured_valid`` (no sensor fitted, or no reading: the speed is
    unknown, never standstill). ``speed_limited``: the speed governor holds the throttle below
    what was asked, or brakes (docs/SAFETY.md row 67)."""

    left_mps: float
    right_mps: float
    measured_valid: bool
    speed_limited: bool = False


@dataclass(frozen=True, slots=True)
class SteeringReport:
    """Steering as applied and as measured; ``measured_norm`` means nothing unless valid."""

    commanded_norm: float
    measured_norm: float
    measured_valid: bool


@dataclass(frozen=True, slots=True)
class LightsReport:
    """Light functions as driven; blinkers report the function, not the flash phase."""

    brake: bool
    reverse: bool
    turn_left: bool
    turn_right: bool
    hazard: bool
    low_beam: bool
    error_led: bool


@dataclass(frozen=True, slots=True)
class StatusReport:
    """Controller health; every field saturates at its DBC maximum (ages: 4095 = never seen)."""

    uptime_s: int
    overrun_count: int
    rc_input_age_ms: int
    can_command_age_ms: int


Report = ModeReport | ErrorReport | WheelSpeedReport | SteeringReport | LightsReport | StatusReport
"""Any report frame's content."""

REPORT_TYPES: tuple[type[Report], ...] = (
    ModeReport,
    ErrorReport,
    WheelSpeedReport,
    SteeringReport,
    LightsReport,
    StatusReport,
)
