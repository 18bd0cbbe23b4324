"""Test helper: real `/bywire/state` messages of a simulated robot on virtual time, made by the
telemetry tap and encoder the feed uses (the dashboard's only input)."""

from __future__ import annotations

from typing import Any

from bywire.config import default_sim_config
from bywire.runtime.settings import RuntimeConfig
from bywire.telemetry.capture import Capture, StateCapture, TelemetryTap
from bywire.telemetry.messages import state_message
from bywire.telemetry.outbox import Outbox
from tests.system.harness import Robot


def state_of(robot: Robot, until_s: float) -> dict[str, Any]:
    """Run `robot` to `until_s` under a tap; the last state message, as a client decodes it."""
    outbox: Outbox[Capture] = Outbox(100_000)
    TelemetryTap(robot.runtime, outbox).attach()
    robot.run(until_s)
    states = [c for c in outbox.take(0.0) if isinstance(c, StateCapture)]
    return state_message(states[-1])


def driving_by_rc(until_s: float = 1.0) -> dict[str, Any]:
    """Armed, then throttle 0.5 by RC from 0.3 s."""
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(0.5))
    return state_of(robot, until_s)


def rc_lost(until_s: float = 1.0) -> dict[str, Any]:
    """Driving by RC, then the receiver unplugged at 0.5 s."""
    robot = Robot.build()
    robot.arm_rc()
    robot.at(0.5, robot.world.rc.link_lost)
    return state_of(robot, until_s)


def full_throttle_limited(until_s: float = 6.0) -> dict[str, Any]:
    """The simulator's own robot file (its speed limit, 2 m/s), full throttle by RC from 0.3 s:
    the governor acts from 1.6 m/s on."""
    robot = Robot.build(RuntimeConfig.from_robot(default_sim_config()))
    robot.arm_rc()
    robot.at(0.3, lambda: robot.world.rc.set_pedal(1.0))
    return state_of(robot, until_s)
