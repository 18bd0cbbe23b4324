"""The feed's topics and their JSON Schemas: one channel per topic, units in every field name.

Foxglove, PlotJuggler and the `mcap` tools read these schemas to type the fields (a plot path like
`/bywire/state.outputs.dac_throttle_volts`). `messages` builds the objects they describe; a test
checks every message against its schema, so the two cannot drift apart.
"""

from __future__ import annotations

from typing import Any

from bywire.command_table import COMMANDS, CommandSpec
from bywire.control.lights import LIGHT_LINES

STATE_TOPIC = "/bywire/state"
EVENTS_TOPIC = "/bywire/events"
CAN_TOPIC = "/bywire/can"
VEHICLE_TOPIC = "/bywire/vehicle"  # the simulated vehicle's pose (bywire sim only)

Schema = dict[str, Any]

_NUMBER: Schema = {"type": "number"}
_OPTIONAL_NUMBER: Schema = {"type": ["number", "null"]}
_INTEGER: Schema = {"type": "integer"}
_BOOLEAN: Schema = {"type": "boolean"}
_STRING: Schema = {"type": "string"}
_NAMES: Schema = {"type": "array", "items": _STRING}


def can_age_key(spec: CommandSpec) -> str:
    """The state's field for the age of a command row's newest frame: one per row of
    `bywire.command_table`, named by its slot (`can_movement_age_s`)."""
    return f"can_{spec.slot}_age_s"


def _object(properties: dict[str, Schema], title: str | None = None) -> Schema:
    """An object with exactly these fields, all required."""
    schema: Schema = {
        "type": "object",
        "properties": properties,
        "required": list(properties),
        "additionalProperties": False,
    }
    return schema if title is None else {"title": title, **schema}


_MOVEMENT = _object(
    {
        "steering_norm": _NUMBER,
        "throttle_norm": _NUMBER,
        "brake_norm": _NUMBER,
        "gear": _STRING,
    }
)
_OPTIONAL_MOVEMENT: Schema = {"anyOf": [_MOVEMENT, {"type": "null"}]}

LIGHTS = tuple(name for name, _ in LIGHT_LINES)
"""The light outputs the state reports, by `LightOutputs`' field names."""
_LIGHTS = _object(dict.fromkeys(LIGHTS, _BOOLEAN))

_OUTPUTS = _object(
    {
        "motors_enabled": _BOOLEAN,
        "forward": _BOOLEAN,
        "reverse": _BOOLEAN,
        "throttle_volts": _NUMBER,
        "regen_volts": _NUMBER,
        "dac_throttle_volts": _OPTIONAL_NUMBER,
        "dac_regen_volts": _OPTIONAL_NUMBER,
        "ebrake_engaged": _BOOLEAN,
        "steering_pulse_ms": _NUMBER,
        "hydrobrake_duty": _NUMBER,
        "lights": _LIGHTS,
    }
)

_INPUTS = _object(
    {
        "rc_age_s": _OPTIONAL_NUMBER,
        **{can_age_key(spec): _OPTIONAL_NUMBER for spec in COMMANDS},
        "rc_frames": _INTEGER,
        "can_control_frames": _INTEGER,
        "rc_request": _OPTIONAL_MOVEMENT,
        "can_movement": _OPTIONAL_MOVEMENT,
        "speed_mps": _OPTIONAL_NUMBER,
        "wheel_left_mps": _OPTIONAL_NUMBER,
        "wheel_right_mps": _OPTIONAL_NUMBER,
        "hydrobrake_pressure_bar": _OPTIONAL_NUMBER,
        "steering_measured_norm": _OPTIONAL_NUMBER,
    }
)

_TASK = _object(
    {
        "name": _STRING,
        "nominal_rate_hz": _NUMBER,
        "rate_hz": _NUMBER,
        "runs": _INTEGER,
        "overruns": _INTEGER,
        "budget_exceeded": _INTEGER,
        "max_jitter_ms": _NUMBER,
        "spent_s": _NUMBER,
    }
)

STATE_SCHEMA = _object(
    {
        "time_s": _NUMBER,
        "elapsed_s": _NUMBER,
        "mode": _STRING,
        "mode_code": _INTEGER,
        "armed": _BOOLEAN,
        "latched_causes": _NAMES,
        "direction_change_held": _BOOLEAN,
        "setpoint_source": _STRING,
        "setpoint": _MOVEMENT,
        "outputs": _OUTPUTS,
        "inputs": _INPUTS,
        "speed_mps": _OPTIONAL_NUMBER,
        "speed_limit": _object({"limit_mps": _OPTIONAL_NUMBER, "acting": _BOOLEAN}),
        "error_flags": _NAMES,
        "error_flags_bits": _INTEGER,
        "watchdog_tripped": _BOOLEAN,
        "reports_sent": _INTEGER,
        "telemetry_dropped": _INTEGER,
        "tasks": {"type": "array", "items": _TASK},
    },
    title="bywire.State",
)

EVENT_SCHEMA = _object(
    {"time_s": _NUMBER, "kind": _STRING, "name": _STRING, "mode": _STRING},
    title="bywire.Event",
)

CAN_SCHEMA = _object(
    {
        "time_s": _NUMBER,
        "arbitration_id": _INTEGER,
        "dlc": _INTEGER,
        "data_bytes": {"type": "array", "items": _INTEGER},
        "data_hex": _STRING,
        "sender": _STRING,
    },
    title="bywire.CanFrame",
)

VEHICLE_SCHEMA = _object(
    {"time_s": _NUMBER, "x_m": _NUMBER, "y_m": _NUMBER, "heading_rad": _NUMBER},
    "bywire.VehiclePose",
)

SCHEMAS: dict[str, Schema] = {
    STATE_TOPIC: STATE_SCHEMA,
    EVENTS_TOPIC: EVENT_SCHEMA,
    CAN_TOPIC: CAN_SCHEMA,
    VEHICLE_TOPIC: VEHICLE_SCHEMA,
}
