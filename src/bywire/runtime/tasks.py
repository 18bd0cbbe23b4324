"""The periodic tasks: what each row of the schedule table runs (thesis Table 1).

Each is a function of the running controller, the decision of this pass and its instant: it
writes its actuator or sends its frames and returns. The rows that name them, with their rates
and budgets, are `bywire.runtime.schedule.SCHEDULE`; a new periodic task is a function here and
a row there.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bywire.control.controller import ControlOutputs
from bywire.control.validity import age_s
from bywire.hal.ports import CanFrame
from bywire.protocol import dbc
from bywire.runtime.reports import Health, build_reports

if TYPE_CHECKING:
    from bywire.runtime.app import Runtime


def write_steering(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_steering(outputs.steering_pulse_s)


def write_drive(runtime: Runtime, outputs: ControlOutputs, now: float) -> None:
    runtime.actuators.write_drive(outputs.drive, now)


def write_brakes(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_brakes(outputs.hydrobrake_duty, outputs.ebrake_engaged)


def write_lights(runtime: Runtime, outputs: ControlOutputs, _now: float) -> None:
    runtime.actuators.write_lights(outputs.lights)


def send_reports(runtime: Runtime, outputs: ControlOutputs, now: float) -> None:
    """Send one full set of reports; on the first refusal give up until the next period.

    Backing off instead of retrying is the fix for §5.2: with the bus unplugged no mailbox
    ever frees, and a task that keeps retrying starves everything below it.
    """
    health = Health(
        uptime_s=now - runtime.started_at,
        overrun_count=runtime.overrun_count,
        rc_age_s=age_s(runtime.inputs.rc, now),
        can_age_s=age_s(runtime.inputs.movement, now),
        wheel_speeds_mps=runtime.sensors.wheel_speeds_mps,
        steering_setpoint_norm=runtime.state.steering.setpoint_norm,
        steering_measured_norm=runtime.sensors.steering_measured_norm,
        encoder_valid_limit_norm=runtime.config.control.monitors.encoder_valid_limit_norm,
    )
    for report in build_reports(outputs, health):
        frame_id, payload = dbc.encode_report(report)
        if not runtime.hardware.can.send(CanFrame(frame_id, payload, now)):
            runtime.tx_faults.happened(now)
            return
        runtime.reports_sent += 1
