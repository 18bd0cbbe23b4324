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

Every command's fate is counted (`Tally`, issue 41 finding 8: a planner whose stamps lagged
0.17 s at 20 Hz never moved the robot, and nothing said why). A command is *refused* when it
fails at arrival, when its stamp ages past the limit while it is held (counted the period it
does), or when it went late (`cmd_timeout_s`) before the next one came (counted as that one
arrives: a planner slower than the timeout, or a pause); it is *accepted* when the next command
replaces it while it is still usable. The silent planner's last command is neither: the bridge
says it is stopping.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace

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


AGEING = (Refusal.STAMP_OLD, Refusal.STAMP_AHEAD)
"""The refusals a held command can come to by itself, counted the period they do."""


@dataclass(frozen=True, slots=True)
class Tally:
    """Every command's fate since start: how many were refused, by reason (in `Refusal`'s
    order), and when (the monotonic clock) the last was refused, accepted and arrived;
    `refusing_since_s`: the first refusal since the last acceptance (None: none since);
    `pending`: the stored set-point's fate is not known yet."""

    refused: tuple[int, ...] = (0,) * len(Refusal)
    last_refusal: Refusal | None = None
    refused_at_s: float | None = None
    accepted_at_s: float | None = None
    arrived_at_s: float | None = None
    refusing_since_s: float | None = None
    pending: bool = False

    @property
    def total_refused(self) -> int:
        return sum(self.refused)

    def count(self, reason: Refusal) -> int:
        return self.refused[list(Refusal).index(reason)]

    def refuse(self, reason: Refusal, at_s: float) -> Tally:
        index = list(Refusal).index(reason)
        counts = tuple(n + (i == index) for i, n in enumerate(self.refused))
        since_s = at_s if self.refusing_since_s is None else self.refusing_since_s
        return replace(
            self, refused=counts, last_refusal=reason, refused_at_s=at_s, refusing_since_s=since_s
        )


def arrived(
    tally: Tally, stored: Setpoint | None, new: Setpoint, settings: BridgeSettings
) -> tuple[Tally, Refusal | None]:
    """A command arrived: None when it is to be stored (then the stored one's fate is settled:
    accepted if still usable, else refused for why not), else why it is refused."""
    at_s = new.arrived_s
    tally = replace(tally, arrived_at_s=at_s)
    refusal = admit(new, settings)
    if refusal is not None:
        return tally.refuse(refusal, at_s), refusal
    if stored is not None and tally.pending:
        why = judge(stored, at_s, settings)
        if why is None:
            tally = replace(tally, accepted_at_s=at_s, refusing_since_s=None)
        else:
            tally = tally.refuse(why, at_s)
    return replace(tally, pending=True), None


def held(tally: Tally, stored: Setpoint | None, now_s: float, settings: BridgeSettings) -> Tally:
    """Each period: the stored command that can no longer be used is refused, once: when its
    stamp has aged past its limit; and when it has gone late while the planner kept sending
    commands that were all refused at arrival (the bridge stops then although its planner
    publishes: B3 of docs/SAFETY.md, found by `bywire verify --seed 1`, campaign 1903, where
    that stop was counted only with the next refusal, up to a planner's period later). A
    command gone late with nothing arriving since is counted when the next one comes, as
    late (a planner slower than `cmd_timeout_s`), or not at all (a planner that stopped)."""
    if stored is None or not tally.pending:
        return tally
    why = judge(stored, now_s, settings)
    live = tally.arrived_at_s is not None and tally.arrived_at_s > stored.arrived_s
    if why in AGEING or (why is Refusal.LATE and live):
        return replace(tally.refuse(why, now_s), pending=False)
    return tally
