"""The ROS 2 tier's rig: the simulated robot served over socketcand (`bywire sim --realtime
--serve`), `bywire ros2` attached to it as a real child process, a bus observer (a third
python-can client), and a client node in the test's process, all confined to this machine:
`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` and a domain of their own per test; meanwhile
`dds_watch.Sniffer` watches every other interface for DDS traffic (it needs root, as CI has).

Imported only where rclpy is (`test_ros_tier.py` skips first without it).
"""

from __future__ import annotations

import contextlib
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool, String
from std_srvs.srv import SetBool, Trigger

from bywire.model import (
    ControlMode,
    ErrorReport,
    ModeReport,
    MovementCommand,
    Report,
    WheelSpeedReport,
)
from bywire.protocol import dbc

STARTUP_S = 20.0
NODE = "/bywire"
LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


def ros_environment(domain_id: int) -> dict[str, str]:
    """This process' environment, confined to this machine and to one DDS domain."""
    return {
        **os.environ,
        "ROS_DOMAIN_ID": str(domain_id),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "PYTHONUNBUFFERED": "1",
    }


def free_domain() -> int:
    """A DDS domain for one test (1..100: the ports of each stay below 32768 on Linux)."""
    return random.Random(os.getpid() ^ time.monotonic_ns()).randrange(1, 101)


def _wait_line(process: subprocess.Popen[str], pattern: str, timeout_s: float) -> re.Match[str]:
    """The first line of the process' stderr matching `pattern` (the rest is drained after)."""
    stream = process.stderr
    if stream is None:
        raise RuntimeError("stderr is not captured")
    deadline = time.monotonic() + timeout_s
    seen: list[str] = []
    while time.monotonic() < deadline:
        line = stream.readline()
        if not line:
            break
        seen.append(line)
        match = re.search(pattern, line)
        if match:
            threading.Thread(target=stream.read, daemon=True).start()  # keep the pipe drained
            return match
    raise RuntimeError(f"no line matching {pattern!r}; got: {''.join(seen)[-2000:]}")


def stop_process(process: subprocess.Popen[str], how: int = signal.SIGINT) -> None:
    """Ask a child to end (it writes its files), and make sure it has."""
    if process.poll() is None:
        process.send_signal(how)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


ROBOT_NICE = -20
NODE_NICE = -5
LINK_PRIORITY = 10


def _child(command: list[str], env: dict[str, str], nice: int) -> subprocess.Popen[str]:
    """A child process with its stderr piped, niced ahead of this process where allowed (root,
    as in CI).

    The simulated robot is a computer of its own and gets the CPU first (`ROBOT_NICE`), as its
    own board would give it. The node is next (`NODE_NICE`), and where it may (root) runs its
    CAN link's thread at SCHED_FIFO `LINK_PRIORITY` itself (`--link-priority`, as on a robot's
    computer); this test's own process stands in for the planner. (Not the whole simulator at
    SCHED_FIFO: its threads would queue behind each other for the interpreter's lock.)
    """

    def lower_nice() -> None:
        with contextlib.suppress(PermissionError):
            os.nice(nice)

    return subprocess.Popen(
        command,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lower_nice,  # noqa: PLW1509 -- only os.nice, before exec
    )


ARM_AT_S = 4.0
SCENARIO = f"""\
# As the packaged `teleop` scenario (the robot waits in CAN mode for an outside computer), but
# its transmitter selects CAN only after the node and the test's client have started: starting
# them is the heaviest moment of the run, and a robot starved past its RC timeout then would
# latch STOP before any test began.
name = "ros2-tier"
description = "waits in CAN mode for bywire ros2"
duration_s = 120.0

[[event]]
at_s = 0.0
fault = "can_silence"

[[event]]
at_s = 0.3
rc = {{ mode = "stop", gear = "neutral", throttle = 0.0 }}

[[event]]
at_s = {ARM_AT_S}
rc = {{ mode = "can" }}
"""


@dataclass
class Sim:
    """`bywire sim --scenario ros2-tier.toml --realtime --serve 0`: waits in CAN mode from
    `ARM_AT_S` for a computer to enable it."""

    process: subprocess.Popen[str]
    port: int
    mcap: Path | None

    @classmethod
    def start(cls, folder: Path, env: dict[str, str], *, record: bool = False) -> Sim:
        """`record`: the controller's telemetry feed to an MCAP file (its own account of
        every frame and mode change, with its clock's times)."""
        scenario = folder / "ros2-tier.toml"
        scenario.write_text(SCENARIO, encoding="utf-8")
        mcap = folder / "sim.mcap" if record else None
        command = [
            *(sys.executable, "-m", "bywire", "sim", "--scenario", str(scenario), "--realtime"),
            *("--serve", "0", "--json"),
            *(() if mcap is None else ("--mcap", str(mcap))),
        ]
        process = _child(command, env, ROBOT_NICE)
        match = _wait_line(process, r"127\.0\.0\.1 port (\d+)", STARTUP_S)
        return cls(process, int(match.group(1)), mcap)


@dataclass
class Bridge:
    """`bywire ros2` on the simulator's port, a real child process."""

    process: subprocess.Popen[str]

    @classmethod
    def start(cls, port: int, env: dict[str, str], *parameters: str) -> Bridge:
        command = [sys.executable, "-m", "bywire", "ros2", "--port", str(port)]
        if os.geteuid() == 0:  # as a robot's computer would run it (CAP_SYS_NICE); CI is root
            command += ["--link-priority", str(LINK_PRIORITY)]
        if parameters:
            command += ["--ros-args", *(item for name in parameters for item in ("-p", name))]
        process = _child(command, env, NODE_NICE)
        _wait_line(process, r"call ~/enable to drive", STARTUP_S)
        return cls(process)


@dataclass
class Observed:
    """A frame the observer saw: the bus time it crossed (the simulator's clock), id, content."""

    time_s: float
    arbitration_id: int
    data: bytes


class Observer(can.Listener):
    """A third client of the simulated bus, keeping every frame with its bus time."""

    def __init__(self, port: int) -> None:
        self.frames: list[Observed] = []
        self._lock = threading.Lock()
        self.bus = can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="can0")
        self.notifier = can.Notifier(self.bus, [self], timeout=0.05)

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            self.frames.append(Observed(msg.timestamp, msg.arbitration_id, bytes(msg.data)))

    def reports(self, kind: type[Report], after_s: float = 0.0) -> list[tuple[float, Any]]:
        """Every report of `kind` after `after_s` (bus time), decoded."""
        frame_id = dbc.frame_id(kind)
        with self._lock:
            frames = [f for f in self.frames if f.arbitration_id == frame_id]
        return [
            (f.time_s, dbc.decode_report(frame_id, f.data)) for f in frames if f.time_s > after_s
        ]

    def movements(self, after_s: float = 0.0) -> list[tuple[float, MovementCommand]]:
        frame_id = dbc.frame_id(MovementCommand)
        with self._lock:
            frames = [f for f in self.frames if f.arbitration_id == frame_id and f.time_s > after_s]
        decoded = [(f.time_s, dbc.decode_command(frame_id, f.data, None)) for f in frames]
        return [(t, m) for t, m in decoded if isinstance(m, MovementCommand)]

    def latest_time_s(self) -> float:
        with self._lock:
            return self.frames[-1].time_s if self.frames else 0.0

    def speeds(self, after_s: float) -> list[tuple[float, float]]:
        return [
            (t, (r.left_mps + r.right_mps) / 2) for t, r in self.reports(WheelSpeedReport, after_s)
        ]

    def modes(self, after_s: float) -> list[tuple[float, ModeReport]]:
        return self.reports(ModeReport, after_s)

    def stops(self, after_s: float) -> list[str]:
        """Each STOP the robot reported after `after_s`: when, and the error flags then up (to
        say why in a failing test's message)."""
        errors = self.reports(ErrorReport, after_s)
        found = []
        for time_s, mode in self.modes(after_s):
            if mode.control_mode is ControlMode.STOP:
                flags = next((r.flags for t, r in errors if t >= time_s), None)
                found.append(f"{time_s:.3f} s: {flags!r}")
        return found[:3]

    def close(self) -> None:
        self.notifier.stop()
        self.bus.shutdown()


class Client:
    """The test's own node: publishes commands, listens to the bridge, calls its services."""

    def __init__(self, domain_id: int) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        node = self.node = rclpy.create_node("bywire_test_client", context=self.context)
        self.lock = threading.Lock()
        self.odom: list[tuple[float, float]] = []
        self.diagnostics: list[Any] = []
        self.mode: list[str] = []
        self.enabled: list[bool] = []
        self.published = 0
        node.create_subscription(Odometry, "/odom", self._on_odom, 10)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._keep(self.diagnostics), 10)
        node.create_subscription(String, f"{NODE}/mode", self._keep_data(self.mode), LATCHED)
        node.create_subscription(Bool, f"{NODE}/enabled", self._keep_data(self.enabled), LATCHED)
        self.cmd_vel = node.create_publisher(TwistStamped, "/cmd_vel", 10)
        self.enable_service = node.create_client(Trigger, f"{NODE}/enable")
        self.remote_stop_service = node.create_client(SetBool, f"{NODE}/remote_stop")
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(node)
        self.spinner = threading.Thread(target=self._spin, daemon=True)
        self.spinner.start()

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # the context shut down under it
                return

    def _on_odom(self, message: Any) -> None:
        with self.lock:
            self.odom.append((time.monotonic(), float(message.twist.twist.linear.x)))

    def _keep(self, into: list[Any]) -> Callable[[Any], None]:
        def keep(message: Any) -> None:
            with self.lock:
                into.append(message)

        return keep

    def _keep_data(self, into: list[Any]) -> Callable[[Any], None]:
        def keep(message: Any) -> None:
            with self.lock:
                into.append(message.data)

        return keep

    def publish(self, speed_mps: float, stamp_age_s: float = 0.0) -> None:
        message = TwistStamped()
        now_ns = self.node.get_clock().now().nanoseconds - round(stamp_age_s * 1e9)
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(now_ns, 1_000_000_000)
        message.twist.linear.x = speed_mps
        self.cmd_vel.publish(message)

    def drive(self, speed_mps: float, seconds: float, stamp_age_s: float = 0.0) -> float:
        """Publish at 20 Hz for `seconds`; the monotonic time of the last message."""
        end = time.monotonic() + seconds
        last = time.monotonic()
        while time.monotonic() < end:
            self.publish(speed_mps, stamp_age_s)
            self.published += 1
            last = time.monotonic()
            time.sleep(0.05)
        return last

    def call(self, service: Any, request: Any, timeout_s: float = 10.0) -> Any:
        if not service.wait_for_service(timeout_sec=timeout_s):
            raise TimeoutError(f"{service.srv_name} not offered")
        future = service.call_async(request)
        deadline = time.monotonic() + timeout_s
        while not future.done():
            if time.monotonic() > deadline:
                raise TimeoutError(f"{service.srv_name} did not answer")
            time.sleep(0.01)
        return future.result()

    def enable(self) -> Any:
        return self.call(self.enable_service, Trigger.Request())

    def remote_stop(self, on: bool) -> Any:
        return self.call(self.remote_stop_service, SetBool.Request(data=on))

    def enable_when_ready(self, timeout_s: float = ARM_AT_S + 10.0) -> Any:
        """Call ~/enable until it arms the robot (the scenario selects CAN at `ARM_AT_S`)."""
        deadline = time.monotonic() + timeout_s
        while True:
            answer = self.enable()
            if answer.success or time.monotonic() > deadline:
                return answer
            time.sleep(0.2)

    def close(self) -> None:
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)
        self.spinner.join(timeout=2.0)


def wait_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()
