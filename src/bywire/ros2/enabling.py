"""Enabling: only an explicit request (the `~/enable` service) ever sends the re-enable edge.

A request starts a pulse: `RE_ENABLE_FRAMES` periods with re-enable high (the previous period's
was low, so the controller sees a rising edge), throttle 0 and the brake applied. Then the answer
waits for a mode report that arrived after the pulse began: CAN mode and nothing latched is
success; at `enable_timeout_s` it is a failure that says why (`robot.why_not_armed`). A command
arriving on `cmd_vel` never enables anything.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.ros2.robot import RobotStatus, why_not_armed
from bywire.teleop.state import RE_ENABLE_FRAMES


class Phase(enum.Enum):
    IDLE = "idle"
    PULSE = "sending the re-enable edge"
    WAIT = "waiting for the robot to arm"


@dataclass(frozen=True, slots=True)
class Answer:
    """The reply to request number `request`."""

    request: int
    armed: bool
    message: str


@dataclass(frozen=True, slots=True)
class Enabling:
    """A request in progress: its number, frames of the pulse left, when the pulse began."""

    phase: Phase = Phase.IDLE
    request: int = 0
    frames_left: int = 0
    since_s: float = 0.0

    @property
    def re_enable(self) -> bool:
        """The re-enable bit of this period's control command."""
        return self.phase is Phase.PULSE


IDLE = Enabling()


def start(request: int, now_s: float, remote_stop: bool) -> tuple[Enabling, Answer | None]:
    """A new request: the pulse begins, or the answer is no at once while remote stop is on."""
    if remote_stop:
        message = "remote stop is on: call ~/remote_stop with data false first"
        return IDLE, Answer(request, False, message)
    return Enabling(Phase.PULSE, request, RE_ENABLE_FRAMES, now_s), None


def advance(
    enabling: Enabling,
    status: RobotStatus,
    mode_arrived_s: float | None,
    now_s: float,
    timeout_s: float,
) -> tuple[Enabling, Answer | None]:
    """After this period's frames: count the pulse down, or judge the robot's newest report."""
    if enabling.phase is Phase.PULSE:
        left = enabling.frames_left - 1
        phase = Phase.PULSE if left > 0 else Phase.WAIT
        return Enabling(phase, enabling.request, left, enabling.since_s), None
    if enabling.phase is Phase.IDLE:
        return enabling, None
    fresh = mode_arrived_s is not None and mode_arrived_s > enabling.since_s
    if fresh and status.drivable:
        return IDLE, Answer(enabling.request, True, "armed: the robot is in CAN mode")
    if now_s - enabling.since_s >= timeout_s:
        return IDLE, Answer(enabling.request, False, why_not_armed(status))
    return enabling, None
