"""The stop ramp: when the planner falls silent, or the robot's speed can no longer be trusted,
brake to standstill, and keep braking until standstill is shown.

The node keeps sending every period, so the controller never sees its own CAN timeout: a network
hiccup on the higher-level side stops the robot gently and leaves it ready to go on, where a
latched STOP would need a re-enable. Throttle is 0 from the first period (the silent command is
never sent again). The brake, by what the bridge knows of the speed:

- **A trusted speed** (`RobotStatus.trusted_speed_mps`): the brake follows a straight line from
  the speed at the start down to 0 at `RAMP_SHARE` of `stop_ramp_s` (a margin for the brakes'
  lag): the brake map's value for the line's deceleration, plus `stop_kp` per m/s above the line.
  Once the line has ended, full brake until a trusted speed at or below `standstill_speed_mps`
  shows standstill (brakes that cannot follow the line leave the robot rolling at its end: it is
  late, never let go); from standstill, the holding brake. So the robot stands within
  `stop_bound_s` of the start.
- **No trusted speed** (SPEED_SENSOR_FAULT in the robot's ErrorReport, or its reports stale):
  full brake for `blind_brake_s` from the period the speed became unknown (the stop bound from the
  fastest speed the settings know of), then the holding brake.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from bywire.ros2.settings import BridgeSettings, interpolate

RAMP_SHARE = 0.8
FULL_BRAKE = 1.0


def strongest_decel_mps2(settings: BridgeSettings) -> float:
    """The least deceleration full brake gives: the brake map's last point (its brake is at most
    full, and the map rises)."""
    return settings.brake_decels_mps2[-1]


def stop_bound_s(speed_mps: float, settings: BridgeSettings) -> float:
    """Standstill, from a ramp started at `speed_mps`, within this: `stop_ramp_s` when the
    brakes can follow the line, else the strongest deceleration's time from that speed plus the
    line's lag margin (the rest of `stop_ramp_s` after `RAMP_SHARE`)."""
    lag_s = (1.0 - RAMP_SHARE) * settings.stop_ramp_s
    return max(settings.stop_ramp_s, abs(speed_mps) / strongest_decel_mps2(settings) + lag_s)


def fastest_mps(settings: BridgeSettings) -> float:
    """The fastest speed the settings know of: either speed limit, or the feed-forward map's top."""
    return max(
        settings.max_speed_mps,
        settings.max_reverse_speed_mps,
        settings.feedforward_speeds_mps[-1],
    )


def blind_brake_s(settings: BridgeSettings) -> float:
    """How long full brake lasts without a trusted speed: the stop bound from `fastest_mps`."""
    return stop_bound_s(fastest_mps(settings), settings)


@dataclass(frozen=True, slots=True)
class StopRamp:
    """Started at `started_s` (monotonic) from `from_speed_mps` (a magnitude; None: started
    without a trusted speed); `blind_since_s`: since when the speed is unknown (None: known)."""

    started_s: float
    from_speed_mps: float | None
    blind_since_s: float | None = None

    def seen(self, now_s: float, speed_mps: float | None) -> StopRamp:
        """The ramp after this period's speed (None: not trusted)."""
        if speed_mps is None:
            return self if self.blind_since_s is not None else replace(self, blind_since_s=now_s)
        return self if self.blind_since_s is None else replace(self, blind_since_s=None)

    def reference_mps(self, now_s: float, settings: BridgeSettings) -> float:
        """The speed the line asks for at `now_s` (0 for a ramp started blind)."""
        if self.from_speed_mps is None:
            return 0.0
        duration_s = RAMP_SHARE * settings.stop_ramp_s
        left = max(0.0, 1.0 - (now_s - self.started_s) / duration_s)
        return self.from_speed_mps * left

    def brake_norm(self, now_s: float, speed_mps: float | None, settings: BridgeSettings) -> float:
        """The brake at `now_s` with the robot at `speed_mps` (a magnitude; None: not trusted,
        call `seen` first)."""
        if speed_mps is None:
            blind_s = now_s - (now_s if self.blind_since_s is None else self.blind_since_s)
            return FULL_BRAKE if blind_s < blind_brake_s(settings) else settings.hold_brake
        if speed_mps <= settings.standstill_speed_mps:
            return settings.hold_brake
        reference = self.reference_mps(now_s, settings)
        if reference <= 0.0 or self.from_speed_mps is None:
            return FULL_BRAKE  # the line has ended and the robot still rolls: it is late
        decel_mps2 = self.from_speed_mps / (RAMP_SHARE * settings.stop_ramp_s)
        feedforward = interpolate(settings.brake_decels_mps2, settings.brake_norms, decel_mps2)
        brake = feedforward + settings.stop_kp * (speed_mps - reference)
        return min(max(brake, 0.0), 1.0)
