"""The schedule table (thesis Table 1): every periodic task, one row each, with what it runs.

A row is ArduPilot's `SCHED_TASK(fn, rate_hz, max_us)`: a name (the configuration overrides its
rate by `[tasks] <name>_rate_hz`), a rate, a budget and the function a pass calls. A new periodic
task is a function here and a row below. The functions write through `TaskTarget`, what a task
needs of the running controller (`bywire.runtime.app.Runtime` is one), so this table sits below
both the configuration, which reads its names and rates, and the runtime, which runs it; the
runtime's own bookkeeping of deadlines and statistics is `bywire.runtime.schedule`.
"""

from __future__ import annotations

from collections.abc import Callable
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


@dataclass(frozen=True, slots=True)
class TaskSpec:
    """One row of the schedule table: what it runs, how often and within what budget."""

    name: str
    rate_hz: float
    budget_s: float
    run: TaskFn

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz


# Table 1 of the thesis: the one schedule table. The RC and CAN readers are event-driven and
# not in it. The rows are in order of importance, which is the order a pass writes in: the brakes
# (the e-brake line, then the hydraulic duty), the steering (one PWM write: the servo holds what
# the decision commanded even if a slow write after it trips the watchdog), then the drive (the
# enable line down first, the slow I2C transfers to the DAC after), the lights and the reports.
SCHEDULE: tuple[TaskSpec, ...] = (
    TaskSpec("hydrobrake", 100.0, 0.002, write_brakes),
    TaskSpec("steering", 100.0, 0.002, write_steering),
    TaskSpec("driving", 100.0, 0.002, write_drive),
    TaskSpec("lights", 20.0, 0.005, write_lights),
    TaskSpec("can_tx", 50.0, 0.004, send_reports),
)
TASK_NAMES = tuple(spec.name for spec in SCHEDULE)
