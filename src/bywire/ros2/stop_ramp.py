"""The stop ramp: when the planner falls silent, brake to standstill within `stop_ramp_s`.

The node keeps sending every period, so the controller never sees its own CAN timeout: a network
hiccup on the higher-level side stops the robot gently and leaves it ready to go on, where a
latched STOP would need a re-enable. Throttle is 0 from the first period (the silent command is
never sent again); the brake follows a straight line from the speed at the start down to 0 at
`RAMP_SHARE` of `stop_ramp_s` (a margin for the brakes' lag): the brake map's value for the line's
deceleration, plus `stop_kp` per m/s above the line. From the end of the ramp, or once standing,
the holding brake.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.ros2.settings import BridgeSettings, interpolate

RAMP_SHARE = 0.8


@dataclass(frozen=True, slots=True)
class StopRamp:
    """Started at `started_s` (monotonic) from `from_speed_mps` (a magnitude)."""

    started_s: float
    from_speed_mps: float

    def reference_mps(self, now_s: float, settings: BridgeSettings) -> float:
        """The speed the line asks for at `now_s`."""
        duration_s = RAMP_SHARE * settings.stop_ramp_s
        left = max(0.0, 1.0 - (now_s - self.started_s) / duration_s)
        return self.from_speed_mps * left

    def brake_norm(self, now_s: float, speed_mps: float, settings: BridgeSettings) -> float:
        """The brake at `now_s` with the robot at `speed_mps` (a magnitude)."""
        reference = self.reference_mps(now_s, settings)
        if reference <= 0.0 or speed_mps <= settings.standstill_speed_mps:
            return settings.hold_brake
        decel_mps2 = self.from_speed_mps / (RAMP_SHARE * settings.stop_ramp_s)
        feedforward = interpolate(settings.brake_decels_mps2, settings.brake_norms, decel_mps2)
        brake = feedforward + settings.stop_kp * (speed_mps - reference)
        return min(max(brake, 0.0), 1.0)
