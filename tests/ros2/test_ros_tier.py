"""The ROS 2 tier: `bywire ros2` under a real rclpy, driving the simulated robot (real CAN frames,
the real controller) served over socketcand, from a test node that publishes TwistStamped.

Needs rclpy (ROS 2 Jazzy's Python wheels from PyPI, in a venv of their own: they install a .pth
hook); `.ci/ros-tier` makes that venv and runs this module, as CI does after the main suite.
Elsewhere the module skips with one line saying so. DDS stays on this machine: every process
runs with `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` in a domain of its own per test, and with
root the module watches every other interface for DDS traffic (RTPS, multicast, IGMP) the whole
time, and fails if any is seen; as a check that the watcher sees, it watches loopback too.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ENABLE_HINT = (
    "ROS 2 tier: rclpy is not installed in this Python; run `.ci/ros-tier` to make .venv-ros"
    " (ROS 2 Jazzy wheels from PyPI) and run it"
)
if os.environ.get("BYWIRE_ROS_TIER") == "1":
    import rclpy  # noqa: F401 -- in the tier a missing rclpy is a failure, not a skip
else:
    pytest.importorskip("rclpy", reason=ENABLE_HINT)

from mcap.reader import make_reader  # noqa: E402

from bywire.error_flags import ErrorFlag  # noqa: E402
from bywire.model import ControlMode, ErrorReport, MovementCommand  # noqa: E402
from bywire.protocol import dbc  # noqa: E402
from bywire.ros2.settings import BridgeSettings  # noqa: E402
from tests.ros2.dds_watch import RTPS_MAGIC, Sniffer, network_interfaces  # noqa: E402
from tests.ros2.tier import (  # noqa: E402
    Bridge,
    Client,
    Observer,
    Sim,
    free_domain,
    ros_environment,
    stop_process,
    wait_until,
)

TARGET_MPS = 0.5
TOLERANCE_MPS = 0.05
# Ages as a planner on a loaded computer needs them (a test process shares two cores with the
# simulated robot, its controller and the node): gaps under 0.4 s are not yet silence.
SETTINGS = BridgeSettings(stop_ramp_s=0.4, cmd_timeout_s=0.4, max_stamp_age_s=0.4)
PARAMETERS = tuple(
    f"{name}:={getattr(SETTINGS, name)}"
    for name in ("stop_ramp_s", "cmd_timeout_s", "max_stamp_age_s")
)
PERIOD_S = 0.02
CAN_TIMEOUT_S = 0.100  # the simulated robot's [timeouts] can_command_timeout_s
CONTROL_PERIOD_S = 0.010  # its 100 Hz control tasks


@dataclass
class Robot:
    sim: Sim
    bridge: Bridge
    observer: Observer
    client: Client


def _watching() -> bool:
    """Whether this run can watch the interfaces (root); in CI's tier it must."""
    if os.geteuid() == 0:
        return True
    if os.environ.get("BYWIRE_ROS_TIER") == "1" and os.environ.get("CI"):
        pytest.fail("the ROS tier in CI checks that no DDS traffic leaves loopback: run as root")
    return False


@pytest.fixture(scope="module")
def sniffers() -> Iterator[None]:
    """With root: DDS packets on any interface but loopback, at any time while the module runs,
    fail it (`test_the_watch_sees_dds_traffic` shows the same watch seeing it on loopback)."""
    if not _watching():
        yield
        return
    _loopback, others = network_interfaces()
    outside = Sniffer(others)
    outside.start()
    yield
    time.sleep(0.5)
    leaked = outside.stop()
    assert leaked == [], f"DDS traffic left the loopback: {[p.summary() for p in leaked[:5]]}"


@pytest.fixture
def robot(
    tmp_path: Path,
    sniffers: None,
    monkeypatch: pytest.MonkeyPatch,
    request: pytest.FixtureRequest,
) -> Iterator[Robot]:
    env = ros_environment(free_domain())
    for name in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(name, env[name])  # the client node in this process too
    sim = Sim.start(tmp_path, env, record=request.node.get_closest_marker("record") is not None)
    bridge = observer = client = None
    try:
        bridge = Bridge.start(sim.port, env, *PARAMETERS)
        observer = Observer(sim.port)
        client = Client(int(env["ROS_DOMAIN_ID"]))
        yield Robot(sim, bridge, observer, client)
    finally:
        for part in (client, observer):
            if part is not None:
                part.close()
        if bridge is not None:
            stop_process(bridge.process)
        stop_process(sim.process)


def _link(robot: Robot) -> dict[str, str]:
    """The node's own account of its CAN link (for a failing test's message)."""
    with robot.client.lock:
        arrays = list(robot.client.diagnostics)
    for array in reversed(arrays):
        for status in array.status:
            if status.name == "bywire: CAN link":
                values = {kv.key: kv.value for kv in status.values}
                return {key: values[key] for key in ("max_period_s", "send_errors", "bus_state")}
    return {}


def _armed(robot: Robot) -> float:
    answer = robot.client.enable_when_ready()
    assert answer.success, answer.message
    return robot.observer.latest_time_s()


def test_twist_drives_the_robot_to_half_a_metre_per_second_and_silence_stops_it(
    robot: Robot,
) -> None:
    armed_s = _armed(robot)
    last_message = robot.client.drive(TARGET_MPS, 7.0)
    stopped_on_bus_s = robot.observer.latest_time_s()

    speeds = [v for t, v in robot.observer.speeds(stopped_on_bus_s - 2.0)]
    assert len(speeds) > 80  # 2 s of 50 Hz wheel-speed reports
    assert all(abs(v - TARGET_MPS) <= TOLERANCE_MPS for v in speeds), (
        speeds,
        robot.observer.stops(armed_s),
        _link(robot),
    )
    with robot.client.lock:
        odom = [v for t, v in robot.client.odom if t > last_message - 2.0]
    assert len(odom) > 50
    assert all(abs(v - TARGET_MPS) <= TOLERANCE_MPS for v in odom), odom

    assert wait_until(lambda: bool(robot.observer.speeds(stopped_on_bus_s + 0.6)), 3.0)
    time.sleep(1.5)  # standing, the node still sending
    after = robot.observer.speeds(stopped_on_bus_s - 0.1)
    moving_until = max(t for t, v in after if v != 0.0)
    standstill_after_s = moving_until - stopped_on_bus_s
    limit_s = SETTINGS.cmd_timeout_s + SETTINGS.stop_ramp_s + 2 * PERIOD_S
    assert standstill_after_s <= limit_s
    assert after[-1][1] == 0.0
    modes = robot.observer.modes(armed_s + 0.1)
    assert {m.control_mode for _t, m in modes} == {ControlMode.CAN}, (
        robot.observer.stops(armed_s),
        _link(robot),
    )
    assert not any(m.stop_latched for _t, m in modes)
    with robot.client.lock:
        assert robot.client.enabled[-1] is True
        assert robot.client.mode[-1] == "CAN armed enabled"
    print(f"standstill {standstill_after_s:.3f} s after the last command crossed the bus")


def test_enable_arms_the_robot_after_a_remote_stop_and_diagnostics_name_the_cause(
    robot: Robot,
) -> None:
    _armed(robot)
    stop = robot.client.remote_stop(True)
    assert stop.success, stop.message
    assert "REMOTE_STOP" in stop.message

    def latched_named() -> bool:
        with robot.client.lock:
            arrays = list(robot.client.diagnostics)
        return any(
            s.name == "bywire: mode" and s.level == b"\x02" and "REMOTE_STOP" in s.message
            for array in arrays[-2:]
            for s in array.status
        )

    assert wait_until(latched_named, 3.0)
    with robot.client.lock:
        assert robot.client.enabled[-1] is False
    refused = robot.client.enable()
    assert not refused.success
    assert "remote stop is on" in refused.message

    released = robot.client.remote_stop(False)
    assert released.success
    armed = robot.client.enable()
    assert armed.success, armed.message
    assert wait_until(lambda: robot.client.enabled[-1] is True, 2.0)
    since_s = robot.observer.latest_time_s()
    assert wait_until(lambda: len(robot.observer.modes(since_s)) > 5, 2.0)
    modes = {m.control_mode for _t, m in robot.observer.modes(since_s)}
    assert modes == {ControlMode.CAN}, (robot.observer.stops(since_s), _link(robot))


def test_a_command_with_a_stale_stamp_is_never_sent(robot: Robot) -> None:
    armed_s = _armed(robot)
    robot.client.drive(TARGET_MPS, 2.0, stamp_age_s=SETTINGS.max_stamp_age_s + 0.1)

    movements = robot.observer.movements(armed_s)
    assert len(movements) > 80
    assert all(m.throttle_norm == 0.0 and m.brake_norm > 0.0 for _t, m in movements)
    assert all(v == 0.0 for _t, v in robot.observer.speeds(armed_s))

    def inputs() -> dict[str, str]:
        with robot.client.lock:
            array = robot.client.diagnostics[-1]
        status = next(s for s in array.status if s.name == "bywire: inputs")
        return {kv.key: kv.value for kv in status.values}

    # cmd_vel is best effort, depth 1 (a late command is worth nothing): a loaded machine may
    # drop some on the way, so every command that arrived is refused, and none was taken.
    sent = robot.client.published
    assert wait_until(lambda: int(inputs()["commands_refused"]) > 0, 2.5), (sent, inputs())
    assert int(inputs()["commands_refused"]) <= sent
    assert inputs()["command_age_s"] == "never", inputs()  # no set-point was ever accepted
    assert inputs()["last_refusal"] == "header stamp older than max_stamp_age_s"


def _mcap_records(path: Path) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """The simulator's own record: (every CAN frame, every event), with its clock's times."""
    frames: list[dict[str, object]] = []
    events: list[dict[str, object]] = []
    with path.open("rb") as stream:
        for _schema, channel, message in make_reader(stream).iter_messages(
            topics=["/bywire/can", "/bywire/events"]
        ):
            record = json.loads(message.data)
            (frames if channel.topic == "/bywire/can" else events).append(record)
    return frames, events


@pytest.mark.record
def test_a_dead_node_is_stopped_by_the_controllers_own_can_timeout(robot: Robot) -> None:
    _armed(robot)
    robot.client.drive(TARGET_MPS, 2.0)
    before_s = robot.observer.latest_time_s() - 0.1
    modes = {m.control_mode for _t, m in robot.observer.modes(before_s)}
    assert modes == {ControlMode.CAN}, (robot.observer.stops(before_s - 2.0), _link(robot))
    robot.bridge.process.send_signal(signal.SIGKILL)  # no goodbye: the process just ends
    robot.bridge.process.wait()
    killed_s = robot.observer.latest_time_s()
    assert wait_until(lambda: len(robot.observer.modes(killed_s + 0.3)) > 0, 3.0)
    errors = robot.observer.reports(ErrorReport, killed_s + 0.2)
    assert ErrorFlag.CAN_COMMAND_TIMEOUT in errors[-1][1].flags
    stop_process(robot.sim.process)

    assert robot.sim.mcap is not None
    frames, events = _mcap_records(robot.sim.mcap)
    movement_id = dbc.frame_id(MovementCommand)  # whose staleness is the CAN timeout's cause
    node_frames = [f for f in frames if f["arbitration_id"] == movement_id and f["sender"] != "hlc"]
    last_command_s = float(node_frames[-1]["time_s"])  # type: ignore[arg-type]
    stop_s = min(
        float(e["time_s"])  # type: ignore[arg-type]
        for e in events
        if e["kind"] == "mode" and e["name"] == "STOP" and float(e["time_s"]) > last_command_s  # type: ignore[arg-type]
    )
    print(f"controller STOP {stop_s - last_command_s:.4f} s after the last movement command")
    assert CAN_TIMEOUT_S <= stop_s - last_command_s <= CAN_TIMEOUT_S + CONTROL_PERIOD_S
    latched = [e for e in events if e["kind"] == "latched" and float(e["time_s"]) >= stop_s - 1e-6]  # type: ignore[arg-type]
    assert latched


def test_the_watch_sees_dds_traffic(sniffers: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """The watch that finds nothing outside finds the tier's own DDS traffic on loopback: it is
    not blind (a watch that dissects nothing would pass every test)."""
    if not _watching():
        pytest.skip("watching interfaces needs root")
    loopback, _others = network_interfaces()
    inside = Sniffer(loopback)
    inside.start()
    domain = free_domain()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    talker, listener = Client(domain), Client(domain)
    try:
        for _ in range(40):
            talker.publish(0.0)
            time.sleep(0.05)
    finally:
        talker.close()
        listener.close()
    seen = inside.stop()
    assert any(RTPS_MAGIC in bytes(packet) for packet in seen)


@pytest.mark.parametrize(
    ("parameter", "quoted"),
    [
        ("stop_ramp_s:=0.6", "stop_ramp_s = 0.6: out of range, allowed 0.3..0.5 s"),
        ("stop_ramp_s:=1", "stop_ramp_s = 1: out of range, allowed 0.3..0.5 s"),
        ("kp:=fast", "kp = 'fast': expected a number, 0..20"),
        ("publish_tf:=3", "publish_tf = 3: expected true or false"),
    ],
)
def test_a_bad_parameter_is_one_line_and_exit_2(
    parameter: str, quoted: str, sniffers: None
) -> None:
    env = ros_environment(free_domain())
    done = subprocess.run(
        [sys.executable, "-m", "bywire", "ros2", "--port", "1", "--ros-args", "-p", parameter],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [f"bywire ros2: error: parameter {quoted}"]
