"""Value types every layer shares: enums and frozen messages whose field names carry their units.

The CAN messages mirror the CAN database (``protocol/albert.dbc``) one to one: each class is named
like its DBC message and each field like its DBC signal, so the codec needs no mapping table. The
codec (``bywire.protocol.dbc``) checks ranges; these types only describe values.

Units in names: ``_norm`` is a normalised set-point (steering −1…1, throttle and brake 0…1),
``_mps`` metres per second, ``_s`` seconds, ``_ms`` milliseconds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import Field, dataclass, fields
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

    def __init__(self, remote_stop: bool, re_enable: bool, counter: int) -> None:
        object.__setattr__(self, "remote_stop", remote_stop)
        object.__setattr__(self, "re_enable", re_enable)
        object.__setattr__(self, "counter", counter)


@dataclass(frozen=True, slots=True)
class MovementCommand(Command):
    """Movement set-points: steering −1 (left)…1 (right), throttle and brake 0…1, gear."""

    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: Gear
    counter: int

    def __init__(
        self,
        steering_norm: float,
        throttle_norm: float,
        brake_norm: float,
        gear: Gear,
        counter: int,
    ) -> None:
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "throttle_norm", throttle_norm)
        object.__setattr__(self, "brake_norm", brake_norm)
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "counter", counter)


@dataclass(frozen=True, slots=True)
class LightsCommand(Command):
    """Light requests; brake, reverse and error lights follow the robot's state instead."""

    turn_left: bool
    turn_right: bool
    hazard: bool
    low_beam: bool
    counter: int

    def __init__(
        self,
        turn_left: bool,
        turn_right: bool,
        hazard: bool,
        low_beam: bool,
        counter: int,
    ) -> None:
        object.__setattr__(self, "turn_left", turn_left)
        object.__setattr__(self, "turn_right", turn_right)
        object.__setattr__(self, "hazard", hazard)
        object.__setattr__(self, "low_beam", low_beam)
        object.__setattr__(self, "counter", counter)


def command_fields(kind: type[Command]) -> tuple[Field[Any], ...]:
    """A command message's fields: each is a dataclass. (`Command` does not tell the type checker
    so itself: mypyc refuses the `if TYPE_CHECKING:` declaration in a class body, issue 43.)"""
    return fields(cast("type[DataclassInstance]", kind))


CommandT = TypeVar("CommandT", bound=Command)


def with_counter(command: CommandT, counter: int) -> CommandT:
    """The same command with another rolling counter: its requests, built anew (what
    `dataclasses.replace` does, without its generic walk over the fields: the simulated
    computer sends a command every 20 ms of each campaign, issue 43)."""
    kind = type(command)
    names = _REQUEST_NAMES.get(kind)
    if names is None:
        names = _REQUEST_NAMES[kind] = request_fields(kind)
    requests = {name: getattr(command, name) for name in names}
    return cast(CommandT, cast(Any, kind)(counter=counter, **requests))


_REQUEST_NAMES: dict[type[Command], tuple[str, ...]] = {}


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

    def __init__(
        self,
        gear: Gear,
        control_mode: ControlMode,
        estop_engaged: bool,
        stop_latched: bool,
        armed: bool,
    ) -> None:
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "control_mode", control_mode)
        object.__setattr__(self, "estop_engaged", estop_engaged)
        object.__setattr__(self, "stop_latched", stop_latched)
        object.__setattr__(self, "armed", armed)


@dataclass(frozen=True, slots=True)
class ErrorReport:
    """The error flags that are up; none means no error. On the bus: one 1-bit signal per flag."""

    flags: ErrorFlag

    def __init__(self, flags: ErrorFlag) -> None:
        object.__setattr__(self, "flags", flags)


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

    def __init__(
        self,
        left_mps: float,
        right_mps: float,
        measured_valid: bool,
        speed_limited: bool = False,
    ) -> None:
        object.__setattr__(self, "left_mps", left_mps)
        object.__setattr__(self, "right_mps", right_mps)
        object.__setattr__(self, "measured_valid", measured_valid)
        object.__setattr__(self, "speed_limited", speed_limited)


@dataclass(frozen=True, slots=True)
class SteeringReport:
    """Steering as applied and as measured; ``measured_norm`` means nothing unless valid."""

    commanded_norm: float
    measured_norm: float
    measured_valid: bool

    def __init__(self, commanded_norm: float, measured_norm: float, measured_valid: bool) -> None:
        object.__setattr__(self, "commanded_norm", commanded_norm)
        object.__setattr__(self, "measured_norm", measured_norm)
        object.__setattr__(self, "measured_valid", measured_valid)


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

    def __init__(  # noqa: PLR0917
        self,
        brake: bool,
        reverse: bool,
        turn_left: bool,
        turn_right: bool,
        hazard: bool,
        low_beam: bool,
        error_led: bool,
    ) -> None:
        object.__setattr__(self, "brake", brake)
        object.__setattr__(self, "reverse", reverse)
        object.__setattr__(self, "turn_left", turn_left)
        object.__setattr__(self, "turn_right", turn_right)
        object.__setattr__(self, "hazard", hazard)
        object.__setattr__(self, "low_beam", low_beam)
        object.__setattr__(self, "error_led", error_led)


@dataclass(frozen=True, slots=True)
class StatusReport:
    """Controller health; every field saturates at its DBC maximum (ages: 4095 = never seen)."""

    uptime_s: int
    overrun_count: int
    rc_input_age_ms: int
    can_command_age_ms: int

    def __init__(
        self,
        uptime_s: int,
        overrun_count: int,
        rc_input_age_ms: int,
        can_command_age_ms: int,
    ) -> None:
        object.__setattr__(self, "uptime_s", uptime_s)
        object.__setattr__(self, "overrun_count", overrun_count)
        object.__setattr__(self, "rc_input_age_ms", rc_input_age_ms)
        object.__setattr__(self, "can_command_age_ms", can_command_age_ms)


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
