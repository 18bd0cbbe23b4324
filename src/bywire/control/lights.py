"""Lights: brake, reverse, turn signals, hazard, low beam and the error LED (thesis §3.4)."""

from __future__ import annotations

import math

from bywire.control.values import value

BRAKE_LIGHT_THRESHOLD_NORM = 0.10
BLINK_RATE_HZ = 1.5


@value
class LightRequest:
    """What the lights task is asked for: the active command, gear and error state."""

    brake_norm: float = 0.0
    reverse_gear: bool = False
    error_flags: int = 0
    turn_left: bool = False
    turn_right: bool = False
    hazard: bool = False
    low_beam: bool = False


@value
class LightOutputs:
    """The level of every light output at one instant."""

    brake: bool = False
    reverse: bool = False
    turn_left: bool = False
    turn_right: bool = False
    low_beam: bool = False
    error_led: bool = False


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
