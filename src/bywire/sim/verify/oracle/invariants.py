"""The output invariants of `docs/SAFETY.md` (H1..H11), the ROS 2 bridge's (B1..B3, judged in
bridge campaigns only), the safe levels each asks for, and a violation of one."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any


class Invariant(StrEnum):
    """One output invariant, by its name in `docs/SAFETY.md`."""

    H1 = "H1"  # no drive without a deliberate act
    H2 = "H2"  # a handover is bumpless for the throttle
    H3 = "H3"  # a watchdog trip is final
    H4 = "H4"  # no drive against the motion
    H5 = "H5"  # STOP is the whole STOP
    H6 = "H6"  # brake beats throttle
    H7 = "H7"  # a stop stops
    H8 = "H8"  # the exit path never gives up
    H9 = "H9"  # a handover is bumpless for the steering
    H10 = "H10"  # a broken brake or servo is acted on
    H11 = "H11"  # the speed limit holds (with a wheel sensor that tells the truth)
    B1 = "B1"  # the bridge, its speed unknown or flagged: bounded throttle, a stop
    B2 = "B2"  # the bridge's stop ramp brakes until standstill
    B3 = "B3"  # every command the bridge refuses is counted, and /diagnostics warns


INVARIANTS: tuple[Invariant, ...] = tuple(Invariant)
OUTPUT_INVARIANTS = tuple(i for i in Invariant if i.startswith("H"))
"""Judged in every campaign."""
BRIDGE_INVARIANTS = tuple(i for i in Invariant if i.startswith("B"))
"""Judged in bridge campaigns, besides `OUTPUT_INVARIANTS`."""

_LEVELS: dict[Invariant, dict[str, Any]] = {
    Invariant.H1: {"ebrake_engaged": True, "throttle_volts_max": 0.0},
    Invariant.H2: {"throttle_volts_max": 0.0},
    Invariant.H3: {"motors_enabled": False, "ebrake_engaged": True, "throttle_volts_max": 0.0},
    Invariant.H4: {"throttle_volts_max": 0.0},
    Invariant.H5: {"hydrobrake_duty_min": 1.0},
    Invariant.H6: {"throttle_volts_max": 0.0},
    Invariant.H7: {"ebrake_engaged": True},
    Invariant.H8: {
        "motors_enabled": False,
        "ebrake_engaged": True,
        "hydrobrake_duty_min": 1.0,
        "throttle_volts_max": 0.0,
    },
    Invariant.H9: {},
    Invariant.H10: {"ebrake_engaged": True},
    Invariant.H11: {},  # with the speed it must not exceed (`speed_max_mps`)
    Invariant.B1: {},  # with the speed it must not exceed (`speed_max_mps`)
    Invariant.B2: {},  # with the standstill it must have reached (`speed_max_mps`)
    Invariant.B3: {"bridge_unshown_drop": False},
}
SAFE_LEVELS: Mapping[Invariant, Mapping[str, Any]] = MappingProxyType(
    {invariant: MappingProxyType(levels) for invariant, levels in _LEVELS.items()}
)
"""What the hardware should show where each invariant broke (a steering pulse held since the
stop is added where that is what broke): the conditions of a scenario's expectation."""


@dataclass(slots=True)
class Violation:
    """One broken invariant: which, when, what the hardware showed and should have shown."""

    invariant: Invariant
    time_s: float
    detail: str
    expected: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, invariant: Invariant, time_s: float, detail: str, **expected: Any) -> Violation:
        """A violation expecting `invariant`'s safe levels, and `expected` besides."""
        return cls(invariant, time_s, detail, {**SAFE_LEVELS[invariant], **expected})
