"""What each value in a scenario may be: checked at load, so a bad one is refused before the run
starts (naming the key, the value and what is allowed) instead of failing halfway through it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from bywire.config.reader import finite
from bywire.model import LIGHT_REQUESTS

Check = Callable[[Any], str | None]
"""A value's check: None when it is allowed, else what is allowed."""

MODES = ("stop", "rc", "can")
GEARS = ("forward", "neutral", "reverse")


def number(low: float, high: float, unit: str = "") -> Check:
    """A finite number (not a bool) in low..high (nan, inf and an integer too big for a float
    are outside every range)."""
    allowed = f"a number in {low:g}..{high:g}{' ' + unit if unit else ''}"

    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return allowed
        number = finite(value)
        return None if number is not None and low <= number <= high else allowed

    return check


def whole(low: int, high: int) -> Check:
    """A whole number (not a bool) in low..high."""
    allowed = f"a whole number in {low}..{high}"

    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, int):
            return allowed
        return None if low <= value <= high else allowed

    return check


def one_of(names: tuple[str, ...]) -> Check:
    """One of `names` (any case)."""
    allowed = "one of " + ", ".join(f'"{name}"' for name in names)

    def check(value: Any) -> str | None:
        return None if isinstance(value, str) and value.lower() in names else allowed

    return check


def flag(value: Any) -> str | None:
    return None if isinstance(value, bool) else "true or false"


MAX_SECONDS = 86_400.0  # a day of simulated time: a scenario is minutes; verify's are 10 s
SECONDS = number(0.0, MAX_SECONDS, "s")
SECONDS_TEXT = f"a time in 0..{MAX_SECONDS:g} s"
NORM = number(-1.0, 1.0)
UNIT = number(0.0, 1.0)

ACTION_VALUES: dict[str, dict[str, Check]] = {
    "rc": {
        "steering": NORM,
        "throttle": NORM,  # below zero: the stick pulled back, braking
        "mode": one_of(MODES),
        "gear": one_of(GEARS),
        "low_beam": flag,
        "hazard": flag,
        "mode_raw": whole(800, 2200),  # the mode switch's pulse in µs, wherever it is
    },
    "hlc": {"steering": NORM, "throttle": UNIT, "brake": UNIT, "gear": one_of(GEARS)},
    "hlc_lights": dict.fromkeys(LIGHT_REQUESTS, flag),
    "hlc_control": {"remote_stop": flag, "re_enable": flag},
    "estop": {"pressed": flag},  # the safety operator's E-stop button (a robot that wires one)
    # with `computer = "bridge"`: the planner feeding the ROS 2 bridge, and its service calls
    "planner": {
        "speed_mps": number(-30.0, 30.0, "m/s"),  # cmd_vel's linear.x
        "curvature_per_m": number(-10.0, 10.0, "1/m"),  # angular.z / linear.x, left > 0
        "rate_hz": number(1.0, 100.0, "Hz"),
        "stamp_lag_s": number(-2.0, 2.0, "s"),  # each header stamp this old when it arrives
        "publishing": flag,  # false: the planner falls silent
    },
    "bridge_service": {"enable": flag, "remote_stop": flag},  # ~/enable, ~/remote_stop
    # the simulated road: its grade, rise over run in the forward direction (-0.1: 10 % downhill)
    "world": {"grade": number(-0.3, 0.3)},
}
"""Every key of every action, with what its value may be."""

OUTPUT_LINES = (
    "motors_enable",
    "motors_forward",
    "motors_reverse",
    "ebrake_release",
    "brake_light",
    "reverse_light",
    "turn_left_light",
    "turn_right_light",
    "low_beam",
    "error_led",
    "steering",
    "hydrobrake",
)
"""Every output a `line_dead` fault may kill: the GPIO lines and the two PWM channels."""

FAULT_VALUES: dict[str, Check] = {
    "count": whole(1, 100_000),
    "load": UNIT,
    "stall_s": number(0.001, 10.0, "s"),
    "line": one_of(OUTPUT_LINES),
    "keyed": flag,
}
