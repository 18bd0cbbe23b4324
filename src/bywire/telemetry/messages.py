"""Captures to messages: pure functions, run in the writer's thread, never in the loop.

Each returns `(topic, message)` where the message is the plain object its topic's JSON Schema
(`schemas`) describes. Times are the controller's clock; ages are taken at the capture's instant.
"""

from __future__ import annotations

from typing import Any

from bywire.control.error_flags import flag_names
from bywire.control.mux import Movement
from bywire.control.rc_mapping import RcRequest
from bywire.control.validity import age_s
from bywire.model import ControlMode, MovementCommand
from bywire.runtime.schedule import TaskSpec
from bywire.telemetry.capture import Capture, EventCapture, StateCapture, TaskCounters
from bywire.telemetry.schemas import CAN_TOPIC, EVENTS_TOPIC, LIGHTS, STATE_TOPIC

Message = dict[str, Any]

SETPOINT_SOURCES = {ControlMode.STOP: "none", ControlMode.RC: "rc", ControlMode.CAN: "can"}
MODE_CODES = {ControlMode.STOP: 0, ControlMode.RC: 1, ControlMode.CAN: 2}  # for plots


def message(capture: Capture) -> tuple[str, Message]:
    """The topic and message for one capture."""
    if isinstance(capture, StateCapture):
        return STATE_TOPIC, state_message(capture)
    if isinstance(capture, EventCapture):
        return EVENTS_TOPIC, {
            "time_s": capture.time_s,
            "kind": capture.kind,
            "name": capture.name,
            "mode": capture.mode,
        }
    return CAN_TOPIC, {
        "time_s": capture.time_s,
        "arbitration_id": capture.arbitration_id,
        "dlc": len(capture.data),
        "data_bytes": list(capture.data),
        "data_hex": capture.data.hex(),
        "sender": capture.sender,
    }


def state_message(capture: StateCapture) -> Message:
    outputs = capture.outputs
    causes = sorted(cause.name for cause in outputs.causes)
    return {
        "time_s": capture.time_s,
        "elapsed_s": capture.elapsed_s,
        "mode": outputs.mode.name,
        "mode_code": MODE_CODES[outputs.mode],
        "armed": not causes,
        "latched_causes": causes,
        "direction_change_held": outputs.direction_change_held,
        "setpoint_source": SETPOINT_SOURCES[outputs.mode],
        "setpoint": _movement(outputs.movement),
        "outputs": _outputs(capture),
        "inputs": _inputs(capture),
        "speed_mps": capture.sensors.speed_mps,
        "error_flags": flag_names(outputs.error_flags),
        "error_flags_bits": outputs.error_flags,
        "watchdog_tripped": capture.watchdog_tripped,
        "reports_sent": capture.reports_sent,
        "telemetry_dropped": capture.telemetry_dropped,
        "tasks": [
            _task(spec, counters, capture.elapsed_s)
            for spec, counters in zip(capture.task_specs, capture.tasks, strict=True)
        ],
    }


def _movement(movement: Movement | MovementCommand | RcRequest) -> Message:
    return {
        "steering_norm": movement.steering_norm,
        "throttle_norm": movement.throttle_norm,
        "brake_norm": movement.brake_norm,
        "gear": movement.gear.name,
    }


def _outputs(capture: StateCapture) -> Message:
    outputs = capture.outputs
    drive, lights = outputs.drive, outputs.lights
    return {
        "motors_enabled": drive.enable,
        "forward": drive.forward,
        "reverse": drive.reverse,
        "throttle_volts": drive.throttle_volts,
        "regen_volts": drive.regen_volts,
        "dac_throttle_volts": capture.dac_throttle_volts,
        "dac_regen_volts": capture.dac_regen_volts,
        "ebrake_engaged": outputs.ebrake_engaged,
        "steering_pulse_ms": outputs.steering_pulse_s * 1000.0,
        "hydrobrake_duty": outputs.hydrobrake_duty,
        "lights": {name: getattr(lights, name) for name in LIGHTS},
    }


def _inputs(capture: StateCapture) -> Message:
    inputs, sensors, now = capture.inputs, capture.sensors, capture.time_s
    rc = None if inputs.rc is None else inputs.rc.value
    wheels = sensors.wheel_speeds_mps
    return {
        "rc_age_s": age_s(inputs.rc, now),
        "can_movement_age_s": age_s(inputs.movement, now),
        "can_lights_age_s": age_s(inputs.lights, now),
        "can_control_age_s": age_s(inputs.control, now),
        "rc_frames": inputs.rc_frames,
        "can_control_frames": inputs.control_frames,
        "rc_request": None if rc is None else _movement(rc),
        "can_movement": None if inputs.movement is None else _movement(inputs.movement.value),
        "speed_mps": sensors.speed_mps,
        "wheel_left_mps": None if wheels is None else wheels[0],
        "wheel_right_mps": None if wheels is None else wheels[1],
        "hydrobrake_pressure_bar": sensors.hydrobrake_pressure_bar,
        "steering_measured_norm": sensors.steering_measured_norm,
    }


def _task(spec: TaskSpec, task: TaskCounters, elapsed_s: float) -> Message:
    return {
        "name": spec.name,
        "nominal_rate_hz": spec.rate_hz,
        "rate_hz": task.runs / elapsed_s if elapsed_s > 0 else 0.0,
        "runs": task.runs,
        "overruns": task.overruns,
        "budget_exceeded": task.budget_exceeded,
        "max_jitter_ms": task.max_jitter_s * 1000.0,
        "spent_s": task.spent_s,
    }
