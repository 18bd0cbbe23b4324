"""The optional feedback sensors, read once per pass: wheel speeds, brake pressure, steering."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.hal.hardware import Hardware


@dataclass(frozen=True, slots=True)
class SensorReadings:
    """One reading of every fitted sensor; None where none is fitted or it gave no reading."""

    wheel_speeds_mps: tuple[float, float] | None = None
    hydrobrake_pressure_bar: float | None = None
    steering_measured_norm: float | None = None

    @property
    def speed_mps(self) -> float | None:
        """The robot's speed: the mean of the two wheels, positive forward."""
        wheels = self.wheel_speeds_mps
        return None if wheels is None else (wheels[0] + wheels[1]) / 2


def read_sensors(hardware: Hardware) -> SensorReadings:
    """Read each fitted sensor once."""
    wheels, pressure = hardware.wheel_speeds, hardware.hydrobrake_pressure_bar
    encoder = hardware.steering_encoder_norm
    return SensorReadings(
        None if wheels is None else wheels.read(),
        None if pressure is None else pressure.read(),
        None if encoder is None else encoder.read(),
    )
