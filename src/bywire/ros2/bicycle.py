"""The bicycle model: a twist's curvature or an Ackermann steering angle to the steering command,
and back from the steering report to a yaw rate for odometry.

Sign conventions: ROS (REP 103) turns left for a positive yaw rate and a positive steering angle;
bywire's steering runs from −1 (full left) to +1 (full right), ±1 being the road-wheel angle
`max_steering_angle_rad` of the robot's `[vehicle]` table. So the angle δ = −steering × max.
For a twist, tan δ = wheelbase × yaw rate / speed (the same in reverse); below
`min_steering_speed_mps` the curvature is undefined and the steering holds (None).
"""

from __future__ import annotations

import math

from bywire.ros2.settings import Geometry


def _clamp_norm(value: float) -> float:
    return min(max(value, -1.0), 1.0)


def steering_from_angle(angle_rad: float, geometry: Geometry) -> float:
    """The steering command (−1…1, clamped at full lock) for a road-wheel angle (left > 0)."""
    if not math.isfinite(angle_rad):
        return 0.0
    return _clamp_norm(-angle_rad / geometry.max_steering_angle_rad)


def steering_from_twist(
    speed_mps: float, yaw_rate_radps: float, geometry: Geometry, min_speed_mps: float
) -> float | None:
    """The steering command for a twist; None (hold the steering) when too slow to tell."""
    if abs(speed_mps) < min_speed_mps or not math.isfinite(yaw_rate_radps):
        return None
    angle_rad = math.atan(geometry.wheelbase_m * yaw_rate_radps / speed_mps)
    return steering_from_angle(angle_rad, geometry)


def yaw_rate_radps(speed_mps: float, steering_norm: float, geometry: Geometry) -> float:
    """The yaw rate a speed and a steering position give (left > 0)."""
    angle_rad = -steering_norm * geometry.max_steering_angle_rad
    return speed_mps * math.tan(angle_rad) / geometry.wheelbase_m
