"""A rosbag2 (MCAP) of the robot's bus: what `ros2 bag`, Foxglove and PlotJuggler open beside a
team's own bags. Written with `rosbags`, which needs no ROS installation.

    /bywire/can            can_msgs/msg/Frame                every frame on the bus
    /bywire/report/<name>  bywire_msgs/msg/<Name>Report      each report decoded (mode, error,
                                                             wheel_speed, steering, lights, status)
    /odom                  nav_msgs/msg/Odometry             dead reckoning from the reports
    /diagnostics           diagnostic_msgs/msg/DiagnosticArray   once a second, as `bywire ros2`

The message definitions of `can_msgs` (as ros2_socketcan publishes it) and of bywire's reports
(one field per DBC signal, units in the names, enums by name) are stored in the bag, so readers
need no package to decode them. Times are the frames' bus times moved to the wall clock of the
run's start (as `bywire sim --log` writes them). Use it as a bus monitor (`__call__`), or feed it
the frames of a log (`add_frame`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import Enum
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from bywire.canlog.read import read_log
from bywire.config import RobotConfig
from bywire.error_flags import flag_names
from bywire.errors import ConfigError, FrameError
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.model import REPORT_TYPES, Report, StatusReport, SteeringReport, WheelSpeedReport
from bywire.protocol import dbc
from bywire.ros2 import diagnostics, odometry
from bywire.ros2.diagnostics import LinkHealth
from bywire.ros2.odometry import Pose
from bywire.ros2.robot import robot_status
from bywire.ros2.settings import Geometry
from bywire.teleop.reports import ReportView, fold

CAN_TOPIC = "/bywire/can"
REPORT_TOPIC = "/bywire/report/"
ODOM_TOPIC = "/odom"
DIAGNOSTICS_TOPIC = "/diagnostics"
FRAME_TYPE = "can_msgs/msg/Frame"
FRAME_MSG = """\
std_msgs/Header header
uint32 id
bool is_rtr
bool is_extended
bool is_error
uint8 dlc
uint8[8] data
"""
DIAGNOSTICS_PERIOD_S = 1.0
REPORT_TIMEOUT_S = 0.2
CHANNEL = "can0"
_FIELD_TYPES = {"bool": "bool", "float": "float64", "int": "int64"}


def report_type(kind: type[Report]) -> str:
    """The ROS type name of a report: bywire_msgs/msg/ModeReport."""
    return f"bywire_msgs/msg/{kind.__name__}"


def report_topic(kind: type[Report]) -> str:
    """/bywire/report/wheel_speed for WheelSpeedReport."""
    name = kind.__name__.removesuffix("Report")
    snake = "".join(f"_{c.lower()}" if c.isupper() else c for c in name).lstrip("_")
    return REPORT_TOPIC + snake


def report_msg(kind: type[Report]) -> str:
    """A report's message definition: a header, then one field per DBC signal (enums by name,
    the error flags as their bits and their names)."""
    lines = ["std_msgs/Header header"]
    for field in fields(kind):
        if field.name == "flags":
            lines += ["uint64 flags", "string[] flag_names"]
        else:
            lines.append(f"{_FIELD_TYPES.get(str(field.type), 'string')} {field.name}")
    return "\n".join(lines) + "\n"


def typestore() -> Typestore:
    """ROS 2 Jazzy's standard types, with can_msgs' Frame and bywire's reports added."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = get_types_from_msg(FRAME_MSG, FRAME_TYPE)
    for kind in REPORT_TYPES:
        types.update(get_types_from_msg(report_msg(kind), report_type(kind)))
    store.register(types)
    return store


def check_bag_path(path: Path) -> None:
    """ConfigError unless `path` names a folder that does not exist yet, in one that does."""
    if path.exists():
        raise ConfigError(f"cannot write a rosbag to {path}: it exists (rosbag2 makes the folder)")
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write a rosbag to {path}: folder {path.parent} does not exist")


@dataclass
class _Connections:
    can: Any
    odom: Any
    diagnostics: Any
    reports: dict[type[Report], Any]


class RosbagExport:
    """Writes the bag as frames arrive; a context manager around the run (closing finishes it)."""

    def __init__(self, path: Path, start_s: float, wall_start_s: float, robot: RobotConfig) -> None:
        check_bag_path(path)
        self.path = path
        self.messages = 0
        self._offset_s = wall_start_s - start_s
        self._geometry = Geometry.of(robot.vehicle)
        self._store = typestore()
        self._writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        try:
            self._writer.open()
        except (OSError, WriterError) as error:
            raise ConfigError(f"cannot write a rosbag to {path}: {error}") from error
        add = self._add
        self._connections = _Connections(
            can=add(CAN_TOPIC, FRAME_TYPE),
            odom=add(ODOM_TOPIC, "nav_msgs/msg/Odometry"),
            diagnostics=add(DIAGNOSTICS_TOPIC, "diagnostic_msgs/msg/DiagnosticArray"),
            reports={kind: add(report_topic(kind), report_type(kind)) for kind in REPORT_TYPES},
        )
        self._view = ReportView()
        self._pose = Pose()
        self.frames = 0
        self._next_diagnostics_s: float | None = None

    def _add(self, topic: str, msgtype: str) -> Any:
        return self._writer.add_connection(topic, msgtype, typestore=self._store)

    def _message(self, msgtype: str, **values: Any) -> Any:
        return self._store.types[msgtype](**values)

    def _header(self, time_s: float, frame_id: str) -> Any:
        stamp_ns = round((time_s + self._offset_s) * 1e9)
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        stamp = self._message("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)
        return self._message("std_msgs/msg/Header", stamp=stamp, frame_id=frame_id)

    def _write(self, connection: Any, time_s: float, message: Any) -> None:
        data = self._store.serialize_cdr(message, connection.msgtype)
        self._writer.write(connection, round((time_s + self._offset_s) * 1e9), data)
        self.messages += 1

    def __call__(self, frame: LoggedFrame) -> None:
        """One frame that crossed the bus (a `SimCanBus` monitor)."""
        self.add_frame(frame.time_s, frame.arbitration_id, frame.data)

    def add_frame(self, time_s: float, arbitration_id: int, data: bytes) -> None:
        """One frame at `time_s` (the run's clock): written, and decoded if it is a report."""
        self.frames += 1
        padded = np.zeros(8, dtype=np.uint8)
        padded[: len(data)] = np.frombuffer(bytes(data[:8]), dtype=np.uint8)
        can_frame = self._message(
            FRAME_TYPE,
            header=self._header(time_s, CHANNEL),
            id=arbitration_id,
            is_rtr=False,
            is_extended=arbitration_id > 0x7FF,
            is_error=False,
            dlc=len(data),
            data=padded,
        )
        self._write(self._connections.can, time_s, can_frame)
        if arbitration_id in dbc.report_ids():
            self._report(time_s, arbitration_id, bytes(data))
        self._diagnostics_due(time_s)

    def _report(self, time_s: float, arbitration_id: int, data: bytes) -> None:
        try:
            report = dbc.decode_report(arbitration_id, data)
        except FrameError:
            return
        self._view = fold(self._view, arbitration_id, data, time_s)
        kind = type(report)
        values: dict[str, Any] = {"header": self._header(time_s, "base_link")}
        for field in fields(report):
            value = getattr(report, field.name)
            if field.name == "flags":
                values.update(flags=int(value), flag_names=flag_names(int(value)))
            else:
                values[field.name] = value.name if isinstance(value, Enum) else value
        self._write(
            self._connections.reports[kind], time_s, self._message(report_type(kind), **values)
        )
        if isinstance(report, WheelSpeedReport):
            steering = self._view.get(SteeringReport)
            self._pose = odometry.advance(self._pose, report, steering, time_s, self._geometry)
            if self._pose.at_s is not None:  # a speed the robot did not measure: no odometry
                self._odometry(time_s)

    def _odometry(self, time_s: float) -> None:
        pose = self._pose
        position = self._message("geometry_msgs/msg/Point", x=pose.x_m, y=pose.y_m, z=0.0)
        orientation = self._message(
            "geometry_msgs/msg/Quaternion",
            x=0.0,
            y=0.0,
            z=math.sin(pose.yaw_rad / 2),
            w=math.cos(pose.yaw_rad / 2),
        )
        linear = self._message("geometry_msgs/msg/Vector3", x=pose.speed_mps, y=0.0, z=0.0)
        angular = self._message("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=pose.yaw_rate_radps)
        message = self._message(
            "nav_msgs/msg/Odometry",
            header=self._header(time_s, "odom"),
            child_frame_id="base_link",
            pose=self._message(
                "geometry_msgs/msg/PoseWithCovariance",
                pose=self._message(
                    "geometry_msgs/msg/Pose", position=position, orientation=orientation
                ),
                covariance=np.array(odometry.POSE_COVARIANCE, dtype=np.float64),
            ),
            twist=self._message(
                "geometry_msgs/msg/TwistWithCovariance",
                twist=self._message("geometry_msgs/msg/Twist", linear=linear, angular=angular),
                covariance=np.array(odometry.TWIST_COVARIANCE, dtype=np.float64),
            ),
        )
        self._write(self._connections.odom, time_s, message)

    def _diagnostics_due(self, time_s: float) -> None:
        if self._next_diagnostics_s is None:
            self._next_diagnostics_s = time_s + DIAGNOSTICS_PERIOD_S
        if time_s < self._next_diagnostics_s:
            return
        self._next_diagnostics_s += DIAGNOSTICS_PERIOD_S
        status = robot_status(self._view, time_s, REPORT_TIMEOUT_S)
        health = LinkHealth(
            bus="active", frames_received=self.frames, bad_frames=self._view.bad_frames
        )
        statuses = diagnostics.statuses(
            status,
            health,
            self._view.get(StatusReport),
            engaged=status.drivable,  # the bus alone cannot tell; driving in CAN mode says so
            remote_stop=False,
        )
        array = self._message(
            "diagnostic_msgs/msg/DiagnosticArray",
            header=self._header(time_s, ""),
            status=[self._status(s) for s in statuses],
        )
        self._write(self._connections.diagnostics, time_s, array)

    def _status(self, status: diagnostics.Status) -> Any:
        return self._message(
            "diagnostic_msgs/msg/DiagnosticStatus",
            level=int(status.level),
            name=status.name,
            message=status.message,
            hardware_id=diagnostics.HARDWARE_ID,
            values=[
                self._message("diagnostic_msgs/msg/KeyValue", key=key, value=value)
                for key, value in status.values
            ],
        )

    def close(self) -> None:
        """Finish the bag (its metadata and the MCAP summary)."""
        self._writer.close()

    def __enter__(self) -> RosbagExport:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()


def export_log(log: Path, bag: Path, robot: RobotConfig) -> tuple[int, str | None]:
    """The rosbag2 of a CAN log (every format `bywire plot` reads): (frames written, where the
    log was cut short, if it was). Times are the log's own."""
    read = read_log(log)
    if not read.messages:
        raise ConfigError(f"{log}: no CAN frames in it")
    start_s = read.messages[0].timestamp
    with RosbagExport(bag, start_s, start_s, robot) as export:
        for message in read.messages:
            if not message.is_extended_id:
                export.add_frame(message.timestamp, message.arbitration_id, bytes(message.data))
        return export.frames, read.stopped
