"""The feed's topics in Foxglove's own terms, beside the JSON ones (`messages`, `schemas`).

- `/bywire/log`: every event (mode change, latch, clear, flag) as a `foxglove.Log`, for the Log
  panel, with a level: a latch or a raised flag is a warning.
- `/bywire/flags`: every error flag by name, true or false, with each state message, so that a
  plot or a state-transitions panel takes `/bywire/flags.RC_TIMEOUT`.
- `/bywire/can/<Message>`: every CAN frame decoded with the DBC (albert.dbc), one topic per
  message, its signals in the DBC's units, as Foxglove's CAN users plot them
  (`/bywire/can/MovementCommand.throttle_norm`); a frame the DBC cannot decode stays on
  `/bywire/can` only.
- `/bywire/pose` (`foxglove.PoseInFrame`) and `/bywire/tf` (`foxglove.FrameTransform`, `world`
  to `base_link`): where the simulated vehicle is, so the 3D panel draws its path.

Used by the writer (its thread or process), never by the loop.
"""

from __future__ import annotations

import json
import math
from typing import Any

import cantools.database.can
import foxglove
from foxglove.channels import FrameTransformChannel, LogChannel, PoseInFrameChannel
from foxglove.messages import (
    FrameTransform,
    Log,
    LogLevel,
    Pose,
    PoseInFrame,
    Quaternion,
    Timestamp,
    Vector3,
)

from bywire.control.error_flags import ErrorFlag
from bywire.protocol.dbc import database
from bywire.telemetry.capture import CanCapture, Capture, EventCapture, PoseCapture, StateCapture

LOG_TOPIC = "/bywire/log"
FLAGS_TOPIC = "/bywire/flags"
CAN_MESSAGES_PREFIX = "/bywire/can/"
POSE_TOPIC = "/bywire/pose"
TRANSFORM_TOPIC = "/bywire/tf"
WORLD_FRAME, ROBOT_FRAME = "world", "base_link"
LOG_NAME = "bywire"

FLAG_NAMES = tuple(str(flag.name) for flag in ErrorFlag)
FLAGS_SCHEMA: dict[str, Any] = {
    "title": "bywire error flags by name",
    "type": "object",
    "properties": {"time_s": {"type": "number"}, **{n: {"type": "boolean"} for n in FLAG_NAMES}},
    "required": ["time_s", *FLAG_NAMES],
    "additionalProperties": False,
}
_LEVELS = {
    "mode": LogLevel.Info,
    "cleared": LogLevel.Info,
    "flag_cleared": LogLevel.Info,
    "latched": LogLevel.Warning,
    "flag_raised": LogLevel.Warning,
}


def can_message_schemas(
    loaded: cantools.database.can.Database | None = None,
) -> dict[str, dict[str, Any]]:
    """Each DBC message's topic and its JSON Schema: `time_s`, `sender` and every signal."""
    loaded = database() if loaded is None else loaded
    schemas = {}
    for message in loaded.messages:
        signals = {signal.name: {"type": "number"} for signal in message.signals}
        properties = {"time_s": {"type": "number"}, "sender": {"type": "string"}, **signals}
        schemas[CAN_MESSAGES_PREFIX + message.name] = {
            "title": f"albert.{message.name}",  # as the DBC names it
            "type": "object",
            "properties": properties,
            "required": ["time_s", "sender"],
            "additionalProperties": False,
        }
    return schemas


def log_message(capture: EventCapture) -> Log:
    """An event as a `foxglove.Log` line."""
    text = {
        "mode": f"mode {capture.name}",
        "latched": f"STOP latched: {capture.name} (mode {capture.mode})",
        "cleared": f"cleared: {capture.name} (mode {capture.mode})",
        "flag_raised": f"error flag raised: {capture.name}",
        "flag_cleared": f"error flag cleared: {capture.name}",
    }.get(capture.kind, f"{capture.kind}: {capture.name}")
    return Log(
        timestamp=_stamp(capture.time_s),
        level=_LEVELS.get(capture.kind, LogLevel.Info),
        message=text,
        name=LOG_NAME,
    )


def flags_message(capture: StateCapture) -> dict[str, Any]:
    """Every error flag by name: set or not."""
    bits = capture.error_flags
    return {"time_s": capture.time_s, **{str(f.name): bool(bits & f) for f in ErrorFlag}}


def _stamp(time_s: float) -> Timestamp:
    seconds = math.floor(time_s)
    return Timestamp(sec=seconds, nsec=round((time_s - seconds) * 1e9) % 1_000_000_000)


def _rotation(heading_rad: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(heading_rad / 2), w=math.cos(heading_rad / 2))


class FoxgloveTopics:
    """The channels above on `context`; `write` logs what a capture gives them."""

    def __init__(self, context: foxglove.Context) -> None:
        self._log = LogChannel(LOG_TOPIC, context=context)
        self._pose = PoseInFrameChannel(POSE_TOPIC, context=context)
        self._transform = FrameTransformChannel(TRANSFORM_TOPIC, context=context)
        self._flags = foxglove.Channel(FLAGS_TOPIC, schema=FLAGS_SCHEMA, context=context)
        self._database = database()
        self._can = {
            topic: foxglove.Channel(topic, schema=schema, context=context)
            for topic, schema in can_message_schemas(self._database).items()
        }

    def write(self, capture: Capture, log_time_ns: int) -> int:
        """Log what `capture` adds to these topics; how many messages that was (0 or 1)."""
        if isinstance(capture, StateCapture):
            self._flags.log(_json(flags_message(capture)), log_time=log_time_ns)
        elif isinstance(capture, EventCapture):
            self._log.log(log_message(capture), log_time=log_time_ns)
        elif isinstance(capture, CanCapture):
            return self._decoded(capture, log_time_ns)
        elif isinstance(capture, PoseCapture):
            self._pose_of(capture, log_time_ns)
        else:
            return 0
        return 1

    def _decoded(self, capture: CanCapture, log_time_ns: int) -> int:
        try:
            message = self._database.get_message_by_frame_id(capture.arbitration_id)
            signals = message.decode_simple(capture.data, decode_choices=False, scaling=True)
        except (KeyError, ValueError, cantools.database.errors.DecodeError):
            return 0  # not in the DBC, or a frame it cannot read: /bywire/can has it
        body = {"time_s": capture.time_s, "sender": capture.sender, **signals}
        self._can[CAN_MESSAGES_PREFIX + message.name].log(_json(body), log_time=log_time_ns)
        return 1

    def _pose_of(self, capture: PoseCapture, log_time_ns: int) -> None:
        stamp = _stamp(capture.time_s)
        position = Vector3(x=capture.x_m, y=capture.y_m, z=0.0)
        rotation = _rotation(capture.heading_rad)
        self._pose.log(
            PoseInFrame(
                timestamp=stamp,
                frame_id=WORLD_FRAME,
                pose=Pose(position=position, orientation=rotation),
            ),
            log_time=log_time_ns,
        )
        self._transform.log(
            FrameTransform(
                timestamp=stamp,
                parent_frame_id=WORLD_FRAME,
                child_frame_id=ROBOT_FRAME,
                translation=position,
                rotation=rotation,
            ),
            log_time=log_time_ns,
        )


def _json(body: dict[str, Any]) -> bytes:
    return json.dumps(body, separators=(",", ":")).encode()


def json_schemas() -> dict[str, dict[str, Any]]:
    """The JSON topics of this module and their schemas (the layout's paths name them)."""
    return {FLAGS_TOPIC: FLAGS_SCHEMA, **can_message_schemas()}
