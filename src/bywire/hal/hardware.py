"""The hardware bundle: every port the controller drives or reads, in one value.

Output levels are chosen so that the de-energised state is the safe one: `motors_enable` low
disables the motor controllers, and `ebrake_release` low leaves the spring-applied emergency brake
engaged. A controller that dies, a cable that falls off or a power-up glitch therefore brakes.

The digital outputs are the lines the controller's own logic drives (a field each) and the lines
of the schedule's line tasks (`bywire.task_table.TaskSpec.lines`), which come from the table: a
new line task adds its lines here, in the robot file's `[tasks]` and in every backend, by its row.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Protocol

from bywire.hal.ports import (
    AnalogInput,
    ByteStream,
    CanPort,
    Clock,
    DigitalIn,
    DigitalOut,
    I2cDevice,
    PwmChannel,
)
from bywire.task_table import TASK_LINES


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
    task_lines: Mapping[str, DigitalOut] = field(default_factory=dict)  # by `TASK_LINES` name

    @classmethod
    def of(cls, lines: Mapping[str, DigitalOut]) -> DigitalOutputs:
        """The bundle of `lines` by name (`OUTPUT_NAMES`): a field each for the wired lines
        (KeyError names one not given), the rest a line task's."""
        wired = {name: lines[name] for name in WIRED_LINES}
        tasks = {name: output for name, output in lines.items() if name not in wired}
        return cls(**wired, task_lines=tasks)

    def line(self, name: str) -> DigitalOut:
        """The output `name` (KeyError for no such line)."""
        if name in WIRED_LINES:
            output: DigitalOut = getattr(self, name)
            return output
        return self.task_lines[name]

    def named(self) -> dict[str, DigitalOut]:
        """Every output by its name: the wired lines, then the line tasks'."""
        return {name: self.line(name) for name in WIRED_LINES} | dict(self.task_lines)

    def all_low(self) -> None:
        """Drive every line low: motors disabled, e-brake engaged, lights off."""
        for output in self.named().values():
            output.set(False)


WIRED_LINES: tuple[str, ...] = tuple(
    line.name for line in fields(DigitalOutputs) if line.name != "task_lines"
)
"""The lines the controller's own logic drives, a field of `DigitalOutputs` each."""
OUTPUT_NAMES: tuple[str, ...] = WIRED_LINES + TASK_LINES
"""Every digital output's name: the fields of `DigitalOutputs`, then the line tasks' lines."""


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
    estop_line: DigitalIn | None = None  # `[estop] line`: high only while released (issue 44)


def sensors_fitted(backend: str) -> bool:
    """Whether the robot on `backend` has the optional sensors (wheel speed, brake pressure,
    steering encoder). The simulated robot has all three; the Linux backend opens none yet
    (docs/DEPLOY.md), so the simulator plays a Linux robot file without them, as it drives, and
    `bywire verify` checks the robot the file describes."""
    return backend == "sim"
