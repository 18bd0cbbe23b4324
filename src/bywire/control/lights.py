"""Lights: brake, reverse, turn signals, hazard, low beam and the error LED (thesis §3.4)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

from bywire.control.values import slot_init

BRAKE_LIGHT_THRESHOLD_NORM = 0.10
BLINK_RATE_HZ = 1.5


@dataclass(frozen=True, slots=True)
class LightRequest:
    """What the lights task is asked for: the active command, gear and error state."""

    brake_norm: float = 0.0
    reverse_gear: bool = False
    error_flags: int = 0
    turn_left: bool = False
    turn_right: bool = False
    hazard: bool = False
    low_beam: bool = False

    def __init__(  # noqa: PLR0917
        self,
        brake_norm: float = 0.0,
        reverse_gear: bool = False,
        error_flags: int = 0,
        turn_left: bool = False,
        turn_right: bool = False,
        hazard: bool = False,
        low_beam: bool = False,
    ) -> None:
        object.__setattr__(self, "brake_norm", brake_norm)
        object.__setattr__(self, "reverse_gear", reverse_gear)
        object.__setattr__(self, "error_flags", error_flags)
        object.__setattr__(self, "turn_left", turn_left)
        object.__setattr__(self, "turn_right", turn_right)
        object.__setattr__(self, "hazard", hazard)
        object.__setattr__(self, "low_beam", low_beam)


slot_init(LightRequest)


@dataclass(frozen=True, slots=True)
class LightLine:
    """Where one light output goes and what it is, read from `LightOutputs`' own fields.

    `line`: its digital line (a field of `DigitalOutputs`, a key of `[lights]`); `description`:
    what it is (scenarios expect `<line> = true` of a steady one as "<description> on");
    `blinks`: its level flashes, so no scenario expects it; `tripped`: its level when the
    watchdog trips (None: it holds what the loop last wrote).
    """

    line: str
    description: str
    blinks: bool = False
    tripped: bool | None = None


def _light(
    line: str, description: str, *, blinks: bool = False, tripped: bool | None = None
) -> Any:
    # A `dataclasses.Field` (typed Any, as `field` itself is to the type checker): mypyc checks
    # a declared return type, and a Field is no bool (issue 43).
    return field(default=False, metadata={"light": LightLine(line, description, blinks, tripped)})


@dataclass(frozen=True, slots=True)
class LightOutputs:
    """The level of every light output at one instant: each field names its line (`LightLine`),
    so the writes, the watchdog's safe levels, the telemetry and the scenarios follow from here."""

    brake: bool = _light("brake_light", "brake lights")
    reverse: bool = _light("reverse_light", "reverse lights")
    turn_left: bool = _light("turn_left_light", "left turn signal", blinks=True)
    turn_right: bool = _light("turn_right_light", "right turn signal", blinks=True)
    low_beam: bool = _light("low_beam", "low beam")
    error_led: bool = _light("error_led", "error LED", tripped=True)

    def __init__(  # noqa: PLR0917
        self,
        brake: bool = False,
        reverse: bool = False,
        turn_left: bool = False,
        turn_right: bool = False,
        low_beam: bool = False,
        error_led: bool = False,
    ) -> None:
        object.__setattr__(self, "brake", brake)
        object.__setattr__(self, "reverse", reverse)
        object.__setattr__(self, "turn_left", turn_left)
        object.__setattr__(self, "turn_right", turn_right)
        object.__setattr__(self, "low_beam", low_beam)
        object.__setattr__(self, "error_led", error_led)


slot_init(LightOutputs)


LIGHT_LINES: tuple[tuple[str, LightLine], ...] = tuple(
    (output.name, output.metadata["light"]) for output in fields(LightOutputs)
)
"""Every light output by its `LightOutputs` field name, with its line, in field order."""


def blink_phase_on(now: float, rate_hz: float = BLINK_RATE_HZ) -> bool:
    """True during the first half of each blink period; every lamp blinks in step."""
    return math.fmod(now * rate_hz, 1.0) < 0.5


def light_outputs(
    request: LightRequest, now: float, blink_rate_hz: float = BLINK_RATE_HZ
) -> LightOutputs:
    """Brake lights above 10 % brake, reverse lights in reverse, error LED on any flag."""
    blink_on = blink_phase_on(now, blink_rate_hz)
    return LightOutputs(
        brake=not request.brake_norm <= BRAKE_LIGHT_THRESHOLD_NORM,  # NaN lights them up
        reverse=request.reverse_gear,
        turn_left=blink_on and (request.turn_left or request.hazard),
        turn_right=blink_on and (request.turn_right or request.hazard),
        low_beam=request.low_beam,
        error_led=request.error_flags != 0,
    )
