"""The optional feedback sensors, read once per pass: wheel speeds, brake pressure, steering.

A sensor that is not fitted is not checked. A fitted sensor that gives no reading (unplugged,
its bus silent) is a different thing: it must not pass for an absent one, or a sensor that dies
quietly would switch its own monitor off. The decision gets an invalid reading (NaN) from it,
which the monitors and the speed check treat as a fault; reports and telemetry still say "no
reading".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.values import slot_init
from bywire.errors import HardwareError
from bywire.hal.hardware import Hardware

NO_READING = math.nan
"""What the decision gets from a fitted sensor that gave no reading: an invalid one."""


@dataclass(frozen=True, slots=True)
class SensorReadings:
    """One reading of every sensor; None where none is fitted or it gave no reading, and which
    sensors are fitted."""

    wheel_speeds_mps: tuple[float, float] | None = None
    hydrobrake_pressure_bar: float | None = None
    steering_measured_norm: float | None = None
    wheels_fitted: bool = False
    pressure_fitted: bool = False
    encoder_fitted: bool = False
    estop_line_high: bool | None = None  # None: no E-stop wired

    def __init__(  # noqa: PLR0917
        self,
        wheel_speeds_mps: tuple[float, float] | None = None,
        hydrobrake_pressure_bar: float | None = None,
        steering_measured_norm: float | None = None,
        wheels_fitted: bool = False,
        pressure_fitted: bool = False,
        encoder_fitted: bool = False,
        estop_line_high: bool | None = None,
    ) -> None:
        object.__setattr__(self, "wheel_speeds_mps", wheel_speeds_mps)
        object.__setattr__(self, "hydrobrake_pressure_bar", hydrobrake_pressure_bar)
        object.__setattr__(self, "steering_measured_norm", steering_measured_norm)
        object.__setattr__(self, "wheels_fitted", wheels_fitted)
        object.__setattr__(self, "pressure_fitted", pressure_fitted)
        object.__setattr__(self, "encoder_fitted", encoder_fitted)
        object.__setattr__(self, "estop_line_high", estop_line_high)

    @property
    def speed_mps(self) -> float | None:
        """The robot's speed: the mean of the two wheels, positive forward."""
        wheels = self.wheel_speeds_mps
        return None if wheels is None else (wheels[0] + wheels[1]) / 2

    @property
    def checked_speed_mps(self) -> float | None:
        """The speed the decision checks: NaN from a fitted sensor that gave none."""
        return _checked(self.speed_mps, self.wheels_fitted)

    @property
    def checked_pressure_bar(self) -> float | None:
        """The pressure the decision checks: NaN from a fitted sensor that gave none."""
        return _checked(self.hydrobrake_pressure_bar, self.pressure_fitted)

    @property
    def checked_steering_norm(self) -> float | None:
        """The steering angle the decision checks: NaN from a fitted encoder that gave none."""
        return _checked(self.steering_measured_norm, self.encoder_fitted)


slot_init(SensorReadings)


def _checked(reading: float | None, fitted: bool) -> float | None:
    return NO_READING if reading is None and fitted else reading


def read_estop(hardware: Hardware) -> bool | None:
    """The E-stop's line (None: none wired); a line that cannot be read reads low: pressed."""
    line = hardware.estop_line
    if line is None:
        return None
    try:
        return line.get()
    except HardwareError:
        return False


def read_sensors(hardware: Hardware) -> SensorReadings:
    """Read each fitted sensor, and the E-stop's line, once."""
    wheels, pressure = hardware.wheel_speeds, hardware.hydrobrake_pressure_bar
    encoder = hardware.steering_encoder_norm
    return SensorReadings(
        None if wheels is None else wheels.read(),
        None if pressure is None else pressure.read(),
        None if encoder is None else encoder.read(),
        wheels_fitted=wheels is not None,
        pressure_fitted=pressure is not None,
        encoder_fitted=encoder is not None,
        estop_line_high=read_estop(hardware),
    )
