"""What the planner asks for, with its two times, and the age gate every use passes through.

A set-point is usable only while both its ages are within their limits:

- by arrival: `now − arrived_s ≤ cmd_timeout_s` (the planner may have died or the network
  stalled: the message stream stopped);
- by header stamp: `|stamp age| ≤ max_stamp_age_s`, where the stamp age grows with the set-point's
  time in the node (a message that took long to arrive, or was replayed from a bag, is old
  however fresh its arrival). A stamp ahead of the node's clock by more than the limit is refused
  too: the two computers' clocks disagree, and its age cannot be known.

`admit` runs when a message arrives: one that fails is never stored, so it is never sent, and a
later check cannot revive it. `usable` runs on every period: a set-point that was fine is dropped
the period its age passes a limit. Plain `Twist` (no header) is gated by arrival only.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.ros2.settings import BridgeSettings


class Source(enum.Enum):
    """Which input a set-point came from."""

    CMD_VEL = "cmd_vel"
    ACKERMANN = "ackermann_cmd"


@dataclass(frozen=True, slots=True)
class Setpoint:
    """A target speed (m/s, negative in reverse) and steering (−1…1; None: hold as it is).

    `arrived_s`: the node's monotonic clock when it arrived; `stamp_age_s`: the node's ROS clock
    minus the header stamp at that moment (None for a message without a header).
    """

    speed_mps: float
    steering_norm: float | None
    arrived_s: float
    stamp_age_s: float | None
    source: Source = Source.CMD_VEL

    def ages_s(self, now_s: float) -> tuple[float, float | None]:
        """(age by arrival, age by stamp) at `now_s` on the monotonic clock."""
        held_s = now_s - self.arrived_s
        return held_s, None if self.stamp_age_s is None else self.stamp_age_s + held_s


class Refusal(enum.Enum):
    """Why a set-point is not used."""

    STAMP_OLD = "header stamp older than max_stamp_age_s"
    STAMP_AHEAD = "header stamp ahead of this computer's clock by more than max_stamp_age_s"
    LATE = "no new command within cmd_timeout_s"
    NOT_FINITE = "speed or steering is not a finite number"


def judge(setpoint: Setpoint, now_s: float, settings: BridgeSettings) -> Refusal | None:
    """Why `setpoint` may not be used at `now_s`, or None when it may."""
    arrival_age_s, stamp_age_s = setpoint.ages_s(now_s)
    if arrival_age_s > settings.cmd_timeout_s:
        return Refusal.LATE
    if stamp_age_s is not None:
        if stamp_age_s > settings.max_stamp_age_s:
            return Refusal.STAMP_OLD
        if stamp_age_s < -settings.max_stamp_age_s:
            return Refusal.STAMP_AHEAD
    return None


def admit(setpoint: Setpoint, settings: BridgeSettings) -> Refusal | None:
    """The check at arrival: None when the set-point may be stored, else why not."""
    steering_ok = setpoint.steering_norm is None or _finite(setpoint.steering_norm)
    if not (_finite(setpoint.speed_mps) and steering_ok):
        return Refusal.NOT_FINITE
    return judge(setpoint, setpoint.arrived_s, settings)


def usable(setpoint: Setpoint | None, now_s: float, settings: BridgeSettings) -> bool:
    """Whether a stored set-point may still drive the robot at `now_s`."""
    return setpoint is not None and judge(setpoint, now_s, settings) is None


def _finite(value: float) -> bool:
    return value - value == 0.0  # False for NaN and both infinities
