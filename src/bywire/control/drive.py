"""Driving motors: throttle and regenerative-brake volts for the DAC, enable and direction GPIO.

All four motor controllers share one command (thesis §3.2, Table 2). The command is clamped in
command units first and again in volts, so neither a bad set-point nor a bad calibration can ask
the DAC for more than its configured maximum. Brake beats throttle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.mux import Movement
from bywire.control.values import slot_init
from bywire.model import Gear


@dataclass(frozen=True, slots=True)
class DriveConfig:
    """Voltage limits of the motor controllers' analogue inputs."""

    max_throttle_volts: float = 5.0
    max_regen_volts: float = 5.0


@dataclass(frozen=True, slots=True)
class DriveOutputs:
    """Levels for Table 2's five signals."""

    throttle_volts: float = 0.0
    regen_volts: float = 0.0
    enable: bool = False
    forward: bool = False
    reverse: bool = False

    def __init__(
        self,
        throttle_volts: float = 0.0,
        regen_volts: float = 0.0,
        enable: bool = False,
        forward: bool = False,
        reverse: bool = False,
    ) -> None:
        object.__setattr__(self, "throttle_volts", throttle_volts)
        object.__setattr__(self, "regen_volts", regen_volts)
        object.__setattr__(self, "enable", enable)
        object.__setattr__(self, "forward", forward)
        object.__setattr__(self, "reverse", reverse)


slot_init(DriveOutputs)


SAFE_DRIVE = DriveOutputs()


def unit_clamp(value: float, nan_value: float) -> float:
    """Clamp into 0…1; NaN becomes `nan_value` (0 for throttle, 1 for brake)."""
    return nan_value if math.isnan(value) else min(max(value, 0.0), 1.0)


def drive_outputs(movement: Movement, enabled: bool, config: DriveConfig) -> DriveOutputs:
    """Table 2 levels for a set-point; disabled means every signal in its safe state."""
    if not enabled:
        return SAFE_DRIVE
    brake_norm = unit_clamp(movement.brake_norm, nan_value=1.0)
    throttle_norm = 0.0 if brake_norm > 0.0 else unit_clamp(movement.throttle_norm, nan_value=0.0)
    if movement.gear is Gear.NEUTRAL:
        throttle_norm = 0.0
    return DriveOutputs(
        throttle_volts=min(throttle_norm * config.max_throttle_volts, config.max_throttle_volts),
        regen_volts=min(brake_norm * config.max_regen_volts, config.max_regen_volts),
        enable=True,
        forward=movement.gear is Gear.FORWARD,
        reverse=movement.gear is Gear.REVERSE,
    )


def braking_drive(previous: DriveOutputs, config: DriveConfig) -> DriveOutputs:
    """A controlled stop's drive (category 1): powered, throttle at 0 V, the regenerative brake
    at full, the direction lines as they were (the motor controllers brake the way they turn)."""
    return DriveOutputs(
        throttle_volts=0.0,
        regen_volts=config.max_regen_volts,
        enable=True,
        forward=previous.forward,
        reverse=previous.reverse,
    )
