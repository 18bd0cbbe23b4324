"""The rclpy shell of `bywire ros2`: topics and services in, `CanLink` calls out, snapshots back.

The only module that imports rclpy. Every decision is in the pure modules; the CAN side runs in
the link's own process (`link_process`). Inputs (`cmd_vel`, `ackermann_cmd`) are turned into
set-points stamped with their arrival (the monotonic clock) and their header stamp's age (this
node's ROS clock); outputs are published from the link's snapshot by timers; the services wait
for the link's answer in a callback group of their own, so topics keep flowing meanwhile.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool, String
from std_srvs.srv import SetBool, Trigger

from bywire.errors import ConfigError
from bywire.ros2 import diagnostics
from bywire.ros2.bicycle import steering_from_angle, steering_from_twist
from bywire.ros2.link import LinkHandle, Snapshot
from bywire.ros2.odometry import POSE_COVARIANCE, TWIST_COVARIANCE, Pose
from bywire.ros2.setpoint import Setpoint, Source
from bywire.ros2.settings import (
    SHELL_PARAMETERS,
    BridgeSettings,
    parameter_defaults,
    settings_from,
)
from bywire.teleop.frames import SEND_PERIOD_S

NODE_NAME = "bywire"
COMMANDS_QOS = QoSProfile(
    depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.BEST_EFFORT
)
"""Best effort, newest only: matches reliable and best-effort publishers alike."""
STATE_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Latched: a late subscriber gets the current value at once."""
STREAM_QOS = 10  # reliable, keep last 10: odom and /diagnostics
DIAGNOSTICS_PERIOD_S = 1.0
REMOTE_STOP_CONFIRM_S = 0.5


def declare_parameters(node: Any) -> tuple[BridgeSettings, dict[str, Any]]:
    """Declare every parameter and read it; ConfigError names a bad one. Declared with dynamic
    typing, so `-p stop_ramp_s:=1` (an integer) is checked by bywire's own rules, not refused
    by rclpy with a traceback."""
    loose = ParameterDescriptor(dynamic_typing=True)
    values: dict[str, object] = {}
    for name, default in parameter_defaults().items():
        value = list(default) if isinstance(default, tuple) else default
        values[name] = node.declare_parameter(name, value, loose).value
    settings = settings_from(values)
    shell: dict[str, Any] = {}
    for name, shell_default in SHELL_PARAMETERS.items():
        given = node.declare_parameter(name, shell_default, loose).value
        if type(given) is not type(shell_default):
            kind = "true or false" if isinstance(shell_default, bool) else "a string"
            raise ConfigError(f"parameter {name} = {given!r}: expected {kind}")
        shell[name] = given
    return settings, shell


def _stamp_s(stamp: Any) -> float:
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


class BridgeNode:
    """The node's topics, services and timers around `link`."""

    def __init__(self, node: Any, link: LinkHandle, shell: dict[str, Any]) -> None:
        self.node = node
        self.link = link
        self.shell = shell
        self._published: dict[str, object] = {}
        self._last_pose_s: float | None = None
        self._logged: dict[str, diagnostics.Level] = {}  # the levels last logged, by status
        services = ReentrantCallbackGroup()
        timers = MutuallyExclusiveCallbackGroup()
        inputs = MutuallyExclusiveCallbackGroup()
        kind = TwistStamped if shell["twist_stamped"] else Twist
        node.create_subscription(
            kind, "cmd_vel", self._on_twist, COMMANDS_QOS, callback_group=inputs
        )
        self._subscribe_ackermann(inputs)
        self.odom = node.create_publisher(Odometry, "odom", STREAM_QOS)
        self.diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", STREAM_QOS)
        self.mode = node.create_publisher(String, "~/mode", STATE_QOS)
        self.enabled = node.create_publisher(Bool, "~/enabled", STATE_QOS)
        self.tf = self._tf_publisher() if shell["publish_tf"] else None
        node.create_service(Trigger, "~/enable", self._on_enable, callback_group=services)
        node.create_service(SetBool, "~/remote_stop", self._on_remote_stop, callback_group=services)
        node.create_timer(SEND_PERIOD_S, self._publish_state, callback_group=timers)
        node.create_timer(DIAGNOSTICS_PERIOD_S, self._publish_diagnostics, callback_group=timers)

    # --- inputs -----------------------------------------------------------------------------

    def _stamp_age_s(self, header: Any) -> float:
        now_s = float(self.node.get_clock().now().nanoseconds) * 1e-9
        return now_s - _stamp_s(header.stamp)

    def _on_twist(self, message: Any) -> None:
        stamped = self.shell["twist_stamped"]
        twist = message.twist if stamped else message
        speed = float(twist.linear.x)
        steering = steering_from_twist(
            speed,
            float(twist.angular.z),
            self.link.geometry,
            self.link.settings.min_steering_speed_mps,
        )
        age = self._stamp_age_s(message.header) if stamped else None
        self._offer(Setpoint(speed, steering, self.link.now(), age, Source.CMD_VEL))

    def _on_ackermann(self, message: Any) -> None:
        drive = message.drive
        steering = steering_from_angle(float(drive.steering_angle), self.link.geometry)
        age = self._stamp_age_s(message.header)
        self._offer(Setpoint(float(drive.speed), steering, self.link.now(), age, Source.ACKERMANN))

    def _offer(self, setpoint: Setpoint) -> None:
        self.link.offer(setpoint)  # refusals are counted there, logged by their state's changes

    def _subscribe_ackermann(self, group: Any) -> None:
        try:
            from ackermann_msgs.msg import AckermannDriveStamped  # noqa: PLC0415 -- optional
        except ImportError:
            self.node.get_logger().info(
                "ackermann_cmd not subscribed: ackermann_msgs is not installed"
                " (apt install ros-$ROS_DISTRO-ackermann-msgs)"
            )
            return
        self.node.create_subscription(
            AckermannDriveStamped,
            "ackermann_cmd",
            self._on_ackermann,
            COMMANDS_QOS,
            callback_group=group,
        )

    def _tf_publisher(self) -> Any:
        try:
            from tf2_msgs.msg import TFMessage  # noqa: PLC0415 -- optional
        except ImportError:
            raise ConfigError(
                "publish_tf needs tf2_msgs, which is not installed"
                " (apt install ros-$ROS_DISTRO-tf2-msgs), or set publish_tf false"
            ) from None
        self._tf_message = TFMessage
        return self.node.create_publisher(TFMessage, "/tf", STREAM_QOS)

    # --- services ---------------------------------------------------------------------------

    def _on_enable(self, _request: Any, response: Any) -> Any:
        number = self.link.request_enable()
        answer = self.link.answer(number, self.link.settings.enable_timeout_s + 1.0)
        if answer is None:
            response.success, response.message = False, "no answer: the CAN link is not running"
        else:
            response.success, response.message = answer.armed, answer.message
        return response

    def _on_remote_stop(self, request: Any, response: Any) -> Any:
        self.link.set_remote_stop(bool(request.data))
        if not request.data:
            response.success = True
            response.message = "remote stop released: call ~/enable to drive again"
            return response
        confirmed = _wait_for(
            lambda: self._confirmed_stop(self.link.snapshot()), REMOTE_STOP_CONFIRM_S
        )
        status = self.link.snapshot().status
        response.success = confirmed
        response.message = (
            f"remote stop on: the robot reports STOP latched by {' '.join(status.latched_causes)}"
            if confirmed
            else "remote stop on and sent every period, but the robot has not reported STOP"
        )
        return response

    @staticmethod
    def _confirmed_stop(snapshot: Snapshot) -> bool:
        return snapshot.status.reporting and "REMOTE_STOP" in snapshot.status.latched_causes

    # --- outputs ----------------------------------------------------------------------------

    def _publish_state(self) -> None:
        snapshot = self.link.snapshot()
        pose = snapshot.pose
        if pose.at_s is not None and pose.at_s != self._last_pose_s:
            self._last_pose_s = pose.at_s
            self._publish_odom(pose)
        self._changed(
            "mode", String(data=diagnostics.mode_line(snapshot.status, snapshot.engaged)), self.mode
        )
        enabled = snapshot.engaged and snapshot.status.drivable
        self._changed("enabled", Bool(data=enabled), self.enabled)

    def _changed(self, key: str, message: Any, publisher: Any) -> None:
        if self._published.get(key) != message:
            self._published[key] = message
            publisher.publish(message)

    def _publish_odom(self, pose: Pose) -> None:
        message = Odometry()
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.header.frame_id = self.shell["odom_frame_id"]
        message.child_frame_id = self.shell["base_frame_id"]
        message.pose.pose.position.x = pose.x_m
        message.pose.pose.position.y = pose.y_m
        message.pose.pose.orientation.z = math.sin(pose.yaw_rad / 2)
        message.pose.pose.orientation.w = math.cos(pose.yaw_rad / 2)
        message.twist.twist.linear.x = pose.speed_mps
        message.twist.twist.angular.z = pose.yaw_rate_radps
        message.pose.covariance = list(POSE_COVARIANCE)
        message.twist.covariance = list(TWIST_COVARIANCE)
        self.odom.publish(message)
        if self.tf is not None:
            self.tf.publish(self._transform(message))

    def _transform(self, odom: Any) -> Any:
        from geometry_msgs.msg import TransformStamped  # noqa: PLC0415 -- with TF only

        transform = TransformStamped()
        transform.header = odom.header
        transform.child_frame_id = odom.child_frame_id
        position = odom.pose.pose.position
        transform.transform.translation.x = position.x
        transform.transform.translation.y = position.y
        transform.transform.rotation = odom.pose.pose.orientation
        return self._tf_message(transforms=[transform])

    def _publish_diagnostics(self) -> None:
        snapshot = self.link.snapshot()
        array = DiagnosticArray()
        array.header.stamp = self.node.get_clock().now().to_msg()
        statuses = diagnostics.statuses(
            snapshot.status,
            snapshot.health,
            snapshot.robot_status_report,
            engaged=snapshot.engaged,
            remote_stop=snapshot.remote_stop,
        )
        self._logged, lines = diagnostics.log_lines(self._logged, statuses)
        logger = self.node.get_logger()
        for level, line in lines:
            if level is diagnostics.Level.ERROR:
                logger.error(line)
            elif level is diagnostics.Level.OK:
                logger.info(line)
            else:
                logger.warn(line)
        for status in statuses:
            array.status.append(
                DiagnosticStatus(
                    level=bytes([int(status.level)]),
                    name=status.name,
                    message=status.message,
                    hardware_id=diagnostics.HARDWARE_ID,
                    values=[KeyValue(key=key, value=value) for key, value in status.values],
                )
            )
        self.diagnostics.publish(array)


def _wait_for(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Poll `condition` until it holds or `timeout_s` passes (in a service callback's thread)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(SEND_PERIOD_S)
    return condition()


def spin(node: Any, stop: Callable[[], bool]) -> None:
    """Run the node's callbacks on a few threads until `stop()` or rclpy shuts down."""
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor  # noqa: PLC0415

    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    try:
        while rclpy.ok() and not stop():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
