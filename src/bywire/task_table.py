"""The schedule table (thesis Table 1): every periodic task, one row each, with what it runs.

A row is ArduPilot's `SCHED_TASK(fn, rate_hz, max_us)`: a name (the configuration overrides its rate
by `[tasks] <name>_rate_hz`, and the row's rate is that key's default), a rate, a budget and the
function a pass calls; and what the rest of the controller derives from it: whether the watchdog
covers it (its rate bounds `timeouts.watchdog_s`), when a changed decision writes it at once rather
than at its next tick, and, for a task that drives GPIO lines only, those lines: the task writes
them through the write gate under its own name, and the watchdog's trip and the safe state
(`bywire.runtime.actuators`) drive them low; each line is an output of the hardware bundle and a
robot-file key `[tasks] <line>_line` (its pin), both derived from the row. A new periodic task is a
function here and a row below, and its rate (and lines) in the robot files. The functions write
through `TaskTarget`, what a task needs of the running controller (`bywire.runtime.loop.Runtime` is
one), so this table sits below both the configuration, which reads its names and rates, and the
runtime, which runs it; the runtime's own bookkeeping of deadlines and statistics is
`bywire.runtime.schedule`.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

from bywire.control.controller import ControlOutputs
from bywire.control.drive import DriveOutputs
from bywire.control.lights import LightOutputs


class TaskActuators(Protocol):
    """The actuator writes the tasks make (`bywire.runtime.actuators.Actuators`)."""

    def write_steering(self, pulse_s: float, hold_pulse_s: float | None = None) -> None: ...

    def write_drive(self, drive: DriveOutputs, now: float) -> None: ...

    def write_brakes(self, hydrobrake_duty: float, ebrake_engaged: bool) -> None: ...

    def write_lights(self, lights: LightOutputs) -> None: ...

    def write_lines(self, task: str, levels: Mapping[str, bool]) -> None:
        """A line task's levels (`TaskSpec.lines`), through the gate under the task's name."""


class TaskTarget(Protocol):
    """What a task needs of the running controller: its actuators and its report sender."""

    @property
    def actuators(self) -> TaskActuators: ...

    def send_reports(self, outputs: ControlOutputs, now: float) -> None: ...


TaskFn = Callable[[TaskTarget, ControlOutputs, float], None]
"""What a row runs: a function of the controller, this pass's decision and its instant."""


def write_steering(target: TaskTarget, outputs: ControlOutputs, _now: float) -> None:
    target.actuators.write_steering(outputs.steering_pulse_s, outputs.steering_hold_pulse_s)


def write_drive(target: TaskTarget, outputs: ControlOutputs, now: float) -> None:
    target.actuators.write_drive(outputs.drive, now)


def write_brakes(target: TaskTarget, outputs: ControlOutputs, _now: float) -> None:
    target.actuators.write_brakes(outputs.hydrobrake_duty, outputs.ebrake_engaged)


def write_lights(target: TaskTarget, outputs: ControlOutputs, _now: float) -> None:
    target.actuators.write_lights(outputs.lights)


def send_reports(target: TaskTarget, outputs: ControlOutputs, now: float) -> None:
    target.send_reports(outputs, now)


def _steering_changed(before: ControlOutputs, after: ControlOutputs) -> bool:
    return after.steering_pulse_s != before.steering_pulse_s


def _drive_changed(before: ControlOutputs, after: ControlOutputs) -> bool:
    # operator.ne, not !=: compiled, mypyc makes != between two instances of an @value class
    # (whose __eq__ its decorator adds) an identity test (issue 43)
    changed: bool = operator.ne(after.drive, before.drive)
    return changed


def _brakes_changed(before: ControlOutputs, after: ControlOutputs) -> bool:
    return (after.hydrobrake_duty, after.ebrake_engaged) != (
        before.hydrobrake_duty,
        before.ebrake_engaged,
    )


Changed = Callable[[ControlOutputs, ControlOutputs], bool]
"""Whether the decision `after` changed what a task writes since `before`."""


@dataclass(frozen=True, slots=True)
class TaskSpec:
    """One row of the schedule table: what it runs, how often and within what budget, and what
    the controller derives from it (see the module's text)."""

    name: str
    rate_hz: float  # the default of `[tasks] <name>_rate_hz`
    budget_s: float
    run: TaskFn
    supervised: bool = False  # the watchdog covers it: its rate bounds `timeouts.watchdog_s`
    changed: Changed | None = None  # written at once when this says the decision changed it
    lines: tuple[str, ...] = ()  # a line task's GPIO outputs (`TASK_LINES`), low when safe

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz


# Table 1 of the thesis: the one schedule table. The RC and CAN readers are event-driven and
# not in it. The rows are in order of importance, which is the order a pass writes in: the brakes
# (the e-brake line, then the hydraulic duty), the steering (one PWM write: the servo holds what
# the decision commanded even if a slow write after it trips the watchdog), then the drive (the
# enable line down first, the slow I2C transfers to the DAC after), the lights and the reports.
SCHEDULE: tuple[TaskSpec, ...] = (
    TaskSpec("hydrobrake", 100.0, 0.002, write_brakes, True, _brakes_changed),
    TaskSpec("steering", 100.0, 0.002, write_steering, True, _steering_changed),
    TaskSpec("driving", 100.0, 0.002, write_drive, True, _drive_changed),
    TaskSpec("lights", 20.0, 0.005, write_lights),
    TaskSpec("can_tx", 50.0, 0.004, send_reports),
)
TASK_NAMES = tuple(spec.name for spec in SCHEDULE)
SUPERVISED_TASKS = tuple(spec.name for spec in SCHEDULE if spec.supervised)
"""The actuator tasks the watchdog covers: the slowest one's rate bounds `timeouts.watchdog_s`."""
LINE_TASKS = tuple(spec for spec in SCHEDULE if spec.lines)
TASK_LINES: tuple[str, ...] = tuple(line for task in LINE_TASKS for line in task.lines)
"""The line tasks' GPIO outputs, in the table's order: each is a `DigitalOutputs` line
(`bywire.hal.hardware`) and a robot-file key `[tasks] <line>_line`, derived from here."""
