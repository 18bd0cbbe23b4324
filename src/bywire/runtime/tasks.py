"""The periodic tasks: what each row of the schedule table runs (thesis Table 1).

Each is a function of the running controller, the decision of this pass and its instant: it
writes its actuator or sends its frames and returns. The rows that name them, with their rates
and budgets, are `bywire.runtime.schedule.SCHEDULE`; a new periodic task is a function here and
a row there. This module stays light: the configuration reads the table's names and rates and
must not pull in the codecs (the reports are built by `Runtime.send_reports`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bywire.control.controller import ControlOutputs

if TYPE_CHECKING:
    from bywire.runtime.app import Runtime


def write_steering(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_steering(outputs.steering_pulse_s, outputs.steering_hold_pulse_s)


def write_drive(runtime: Runtime, outputs: ControlOutputs, now: float) -> None:
    runtime.actuators.write_drive(outputs.drive, now)


def write_brakes(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_brakes(outputs.hydrobrake_duty, outputs.ebrake_engaged)


def write_lights(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_lights(outputs.lights)


def send_reports(runtime: Runtime, outputs: ControlOutputs, now: float) -> None:
    runtime.send_reports(outputs, now)
