"""`bywire ros2`: the higher-level computer's ROS 2 node, owning the robot's CAN bus.

rclpy comes from the ROS 2 installation (`source /opt/ros/jazzy/setup.bash`), never from
bywire's own dependencies; without it this command says so in one line (exit 2).
"""

from __future__ import annotations

import argparse
import functools
import logging
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bywire.cli.bus_options import add_bus_options, bus_from_args, bus_source
from bywire.config import default_sim_config, load_config
from bywire.config.security_setup import sender_signer
from bywire.errors import HardwareError
from bywire.protocol import dbc
from bywire.ros2.settings import Geometry, capped_by
from bywire.security.keys import read_key_file
from bywire.security.session import TRIP_IDS

if TYPE_CHECKING:
    from bywire.security.session import SecocSigner

STANDARD_ID_MASK = 0x7FF
DEFAULT_FRESHNESS = Path.home() / ".local" / "state" / "bywire" / "ros2-freshness.json"
NO_RCLPY = (
    "bywire ros2 needs rclpy from a ROS 2 installation, which this Python cannot import:"
    " source /opt/ros/jazzy/setup.bash (or your distribution's) in this shell first, with"
    " bywire installed in that Python (pip install 'bywire[ros]')"
)

EPILOG = """\
topics and services (docs/ROS2.md): in cmd_vel (geometry_msgs/TwistStamped; plain Twist with
-p twist_stamped:=false) and ackermann_cmd (ackermann_msgs/AckermannDriveStamped, when
installed); out odom, /diagnostics, ~/mode, ~/enabled; services ~/enable (std_srvs/Trigger) and
~/remote_stop (std_srvs/SetBool). The robot drives only after a successful ~/enable call.

examples:
  # the simulator, started by `bywire sim --scenario teleop --realtime --serve 29536`
  bywire ros2
  ros2 service call /bywire/enable std_srvs/srv/Trigger
  # the robot's bus, its geometry, a slower planner, a 0.5 s stop ramp
  bywire ros2 -i socketcan -c can0 --config robot.toml --ros-args \\
      -p cmd_timeout_s:=0.3 -p stop_ramp_s:=0.5
  # a CAN log as a rosbag2 for ros2 bag and Foxglove (no ROS needed)
  bywire ros2 --export drive.blf drive-bag
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    add_bus_options(parser)
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="the robot's configuration TOML, for its [vehicle] geometry (default: the"
        " simulator's)",
    )
    parser.add_argument(
        "--key",
        type=Path,
        metavar="FILE",
        help="sign every command (SecOC, for a robot with [security] enabled) with this key file",
    )
    parser.add_argument(
        "--freshness",
        type=Path,
        metavar="FILE",
        default=DEFAULT_FRESHNESS,
        help="with --key: this sender's freshness values across restarts (default: %(default)s)",
    )
    parser.add_argument(
        "--link-priority",
        type=int,
        choices=range(1, 99),
        metavar="1..98",
        help="run the CAN link's thread at this SCHED_FIFO priority (needs CAP_SYS_NICE), so a"
        " busy planner on this computer cannot starve it past the robot's CAN timeout",
    )
    parser.add_argument(
        "--export",
        nargs=2,
        type=Path,
        metavar=("LOG", "DIR"),
        help="instead of running: write the rosbag2 (MCAP) of a CAN log (BLF, ASC, candump, …)"
        " to the new folder DIR, as bywire sim --rosbag does (no ROS needed), and exit",
    )
    parser.add_argument(
        "--ros-args",
        dest="ros_args",
        nargs=argparse.REMAINDER,
        default=[],
        metavar="ARG",
        help="everything after it goes to ROS: -p NAME:=VALUE, -r FROM:=TO, --params-file FILE",
    )


def run(args: argparse.Namespace) -> int:
    if args.export is not None:
        return _export(args)
    try:
        import rclpy  # noqa: PLC0415 -- optional: ROS 2's own Python package
    except ImportError:
        raise HardwareError(NO_RCLPY) from None
    robot = default_sim_config() if args.config is None else load_config(args.config)
    geometry = Geometry.of(robot.vehicle)
    rclpy.init(args=["bywire", "--ros-args", *args.ros_args])
    try:
        limit_mps = robot.limits.max_speed_mps
        return _serve(rclpy, args, geometry, limit_mps, defaults=args.config is None)
    finally:
        if rclpy.ok():
            rclpy.shutdown()


def _serve(
    rclpy: Any,
    args: argparse.Namespace,
    geometry: Geometry,
    limit_mps: float | None,
    *,
    defaults: bool,
) -> int:
    from bywire.ros2.link_process import LinkOptions, LinkProcess  # noqa: PLC0415
    from bywire.ros2.node import NODE_NAME, BridgeNode, declare_parameters, spin  # noqa: PLC0415

    node = rclpy.create_node(NODE_NAME)
    settings, shell = declare_parameters(node)
    settings = capped_by(settings, limit_mps)  # the robot's speed limit gates cmd_vel too
    opener = functools.partial(open_link, _bus_options(args), args.key, args.freshness)
    link = LinkProcess(opener, LinkOptions(settings, geometry, args.link_priority))
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda _number, _frame: stop.set())
    try:
        BridgeNode(node, link, shell)
        where = " (the simulator's geometry: give --config for your robot)" if defaults else ""
        node.get_logger().info(f"on {bus_source(args)}{where}; call ~/enable to drive")
        spin(node, lambda: stop.is_set() or not link.alive)
        if link.failure is not None:
            raise HardwareError(str(link.failure))
    finally:
        signal.signal(signal.SIGTERM, previous)
        link.close()
        node.destroy_node()
    return 0


BUS_OPTIONS = ("interface", "channel", "bus_kwargs", "host", "port", "bitrate")


def _bus_options(args: argparse.Namespace) -> dict[str, Any]:
    """The bus options as plain values, for the link's process."""
    return {name: getattr(args, name) for name in BUS_OPTIONS}


def open_link(
    bus_options: dict[str, Any], key: Path | None, freshness: Path
) -> tuple[Any, SecocSigner | None]:
    """In the link's process: the bus (filtered to the robot's reports, and its trip counter
    when signing) and the signer."""
    signer = None if key is None else _signer(key, freshness)
    return _open_bus(argparse.Namespace(**bus_options), signing=signer is not None), signer


def _export(args: argparse.Namespace) -> int:
    """A CAN log to a rosbag2; rosbags (bywire[ros]) is all it needs."""
    from bywire.cli.sim import rosbag_module  # noqa: PLC0415 -- says how to get rosbags

    log, bag = args.export
    robot = default_sim_config() if args.config is None else load_config(args.config)
    frames, stopped = rosbag_module().export_log(log, bag, robot)
    print(f"rosbag2: {bag} ({frames} frames of {log}; ros2 bag info {bag})")
    if stopped is not None:
        print(f"warning: {log} stops early: {stopped}", file=sys.stderr)
    return 0


def _open_bus(args: argparse.Namespace, *, signing: bool = False) -> Any:
    filters: list[Any] = [
        {"can_id": frame_id, "can_mask": STANDARD_ID_MASK, "extended": False}
        for frame_id in (*dbc.report_ids(), *(sorted(TRIP_IDS) if signing else ()))
    ]
    logging.getLogger("can").setLevel(logging.ERROR)
    return bus_from_args(args, can_filters=filters)


def _signer(key_file: Path, freshness: Path) -> SecocSigner:
    key = read_key_file(key_file)
    freshness.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    return sender_signer(key, freshness)
