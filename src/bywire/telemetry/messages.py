"""Captures to messages: pure functions, run by the writer, never in the loop.

Each returns `(topic, message)` where the message is the plain object its topic's JSON Schema
(`schemas`) describes. Times are the controller's clock; ages were taken at the capture's instant.
"""

from __future__ import annotations

from typing import Any

from bywire.command_table import COMMANDS
from bywire.error_flags import flag_names
from bywire.telemetry.capture import (
    Capture,
    EventCapture,
    MovementValues,
    PoseCapture,
    StateCapture,
    TaskRow,
)
from bywire.telemetry.schemas import (
    CAN_TOPIC,
    EVENTS_TOPIC,
    LIGHTS,
    STATE_TOPIC,
    VEHICLE_TOPIC,
    can_age_key,
)

Message = dict[str, Any]

SETPOINT_SOURCES = {"STOP": "none", "RC": "rc", "CAN": "can"}
MODE_CODES = {"STOP": 0, "RC": 1, "CAN": 2}  # for plots


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
    if isinstance(capture, PoseCapture):
        return VEHICLE_TOPIC, {
            "time_s": capture.time_s,
            "x_m": capture.x_m,
            "y_m": capture.y_m,
            "heading_rad": capture.heading_rad,
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
    causes = list(capture.latched_causes)
    return {
        "time_s": capture.time_s,
        "elapsed_s": capture.elapsed_s,
        "mode": capture.mode,
        "mode_code": MODE_CODES[capture.mode],
        "armed": not causes,
        "latched_causes": causes,
        "direction_change_held": capture.direction_change_held,
        "setpoint_source": SETPOINT_SOURCES[capture.mode],
        "setpoint": _movement(capture.setpoint),
        "outputs": _outputs(capture),
        "inputs": _inputs(capture),
        "speed_mps": capture.speed_mps,
        "speed_limit": {"limit_mps": capture.speed_limit_mps, "acting": capture.speed_limited},
        "error_flags": flag_names(capture.error_flags),
        "error_flags_bits": capture.error_flags,
        "watchdog_tripped": capture.watchdog_tripped,
        "reports_sent": capture.reports_sent,
        "telemetry_dropped": capture.telemetry_dropped,
        "tasks": [_task(row, capture.elapsed_s) for row in capture.tasks],
    }


def _movement(movement: MovementValues) -> Message:
    steering_norm, throttle_norm, brake_norm, gear = movement
    return {
        "steering_norm": steering_norm,
        "throttle_norm": throttle_norm,
        "brake_norm": brake_norm,
        "gear": gear,
    }


def _optional_movement(movement: MovementValues | None) -> Message | None:
    return None if movement is None else _movement(movement)


def _outputs(capture: StateCapture) -> Message:
    return {
        "motors_enabled": capture.motors_enabled,
        "forward": capture.forward,
        "reverse": capture.reverse,
        "throttle_volts": capture.throttle_volts,
        "regen_volts": capture.regen_volts,
        "dac_throttle_volts": capture.dac_throttle_volts,
        "dac_regen_volts": capture.dac_regen_volts,
        "ebrake_engaged": capture.ebrake_engaged,
        "steering_pulse_ms": capture.steering_pulse_s * 1000.0,
        "hydrobrake_duty": capture.hydrobrake_duty,
        "lights": dict(zip(LIGHTS, capture.lights, strict=True)),
    }


def _inputs(capture: StateCapture) -> Message:
    return {
        "rc_age_s": capture.rc_age_s,
        **{can_age_key(spec): age for spec, age in zip(COMMANDS, capture.can_ages_s, strict=True)},
        "rc_frames": capture.rc_frames,
        "can_control_frames": capture.can_control_frames,
        "rc_request": _optional_movement(capture.rc_request),
        "can_movement": _optional_movement(capture.can_movement),
        "speed_mps": capture.speed_mps,
        "wheel_left_mps": capture.wheel_left_mps,
        "wheel_right_mps": capture.wheel_right_mps,
        "hydrobrake_pressure_bar": capture.hydrobrake_pressure_bar,
        "steering_measured_norm": capture.steering_measured_norm,
    }


def _task(row: TaskRow, elapsed_s: float) -> Message:
    name, nominal_rate_hz, runs, overruns, budget_exceeded, max_jitter_s, spent_s = row
    return {
        "name": name,
        "nominal_rate_hz": nominal_rate_hz,
        "rate_hz": runs / elapsed_s if elapsed_s > 0 else 0.0,
        "runs": runs,
        "overruns": overruns,
        "budget_exceeded": budget_exceeded,
        "max_jitter_ms": max_jitter_s * 1000.0,
        "spent_s": spent_s,
    }
