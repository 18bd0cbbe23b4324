"""The hardware bundle: every port the controller drives or reads, in one value.

Output levels are chosen so that the de-energised state is the safe one: `motors_enable` low
disables the motor controllers, and `ebrake_release` low leaves the spring-applied emergency brake
engaged. A controller that dies, a cable that falls off or a power-up glitch therefore brakes.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Protocol

from bywire.hal.ports import (
    AnalogInput,
    ByteStream,
    CanPort,
    Clock,
    DigitalOut,
    I2cDevice,
    PwmChannel,
)


class WheelSpeedSensor(Protocol):
    """Left and right wheel speeds, positive forward."""

    def read(self) -> tuple[float, float] | None:
        """(left_mps, right_mps), or None when no reading is available."""
        ...


@dataclass(frozen=True, slots=True)
class DigitalOutputs:
    """Every GPIO the controller drives (Table 2's motor lines, the e-brake and the lights)."""

    motors_enable: DigitalOut
    motors_forward: DigitalOut
    motors_reverse: DigitalOut
    ebrake_release: DigitalOut
    brake_light: DigitalOut
    reverse_light: DigitalOut
    turn_left_light: DigitalOut
    turn_right_light: DigitalOut
    low_beam: DigitalOut
    error_led: DigitalOut

    def all_low(self) -> None:
        """Drive every line low: motors disabled, e-brake engaged, lights off."""
        for line in fields(self):
            getattr(self, line.name).set(False)


@dataclass(frozen=True, slots=True)
class Hardware:
    """The ports of one robot, simulated or real."""

    clock: Clock
    can: CanPort
    rc_uart: ByteStream
    dac: I2cDevice
    steering_pwm: PwmChannel
    hydrobrake_pwm: PwmChannel
    outputs: DigitalOutputs
    wheel_speeds: WheelSpeedSensor | None = None
    hydrobrake_pressure_bar: AnalogInput | None = None  # optional (Table 4): checked if fitted
    steering_encoder_norm: AnalogInput | None = None  # optional (Table 4): −1…1 like the command


def sensors_fitted(backend: str) -> bool:
    """Whether the robot on `backend` has the optional sensors (wheel speed, brake pressure,
    steering encoder). The simulated robot has all three; the Linux backend opens none yet
    (docs/DEPLOY.md), so the simulator plays a Linux robot file without them, as it drives, and
    `bywire verify` checks the robot the file describes."""
    return backend == "sim"
