"""Dead reckoning from the robot's reports: speed from the wheel-speed report, yaw rate from the
steering report through the bicycle model, integrated at each wheel-speed report's arrival.

Pure: `advance` takes the report's values and its arrival time. The speed is the mean of the two
wheels; the steering is the measured one when the robot has an encoder (`measured_valid`), else
the commanded one as applied. A gap longer than `MAX_STEP_S` is not bridged (the robot was not
heard from; it may have moved any way): the pose holds and integration starts again. A report
that measures no speed (`measured_valid` 0: no wheel sensor, or no reading) is not integrated
as standstill: the pose holds with no time (`at_s` None), so no odometry is published from it
and integration starts again at the next measured report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.model import SteeringReport, WheelSpeedReport
from bywire.ros2.bicycle import yaw_rate_radps
from bywire.ros2.settings import Geometry

MAX_STEP_S = 0.5
UNKNOWN = 1e6


def _diagonal(*variances: float) -> tuple[float, ...]:
    """A 6×6 covariance, row-major, with these variances on its diagonal."""
    return tuple(variances[i // 6] if i % 7 == 0 else 0.0 for i in range(36))


# Wheel odometry: position uncertain to a few percent of the distance, heading more so; the axes
# a planar robot does not measure (z, roll, pitch; sideways speed) effectively unknown.
POSE_COVARIANCE = _diagonal(0.05, 0.05, UNKNOWN, UNKNOWN, UNKNOWN, 0.1)
TWIST_COVARIANCE = _diagonal(0.01, UNKNOWN, UNKNOWN, UNKNOWN, UNKNOWN, 0.05)


@dataclass(frozen=True, slots=True)
class Pose:
    """Position in the odometry frame, heading (left > 0), and the latest velocities."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0
    speed_mps: float = 0.0
    yaw_rate_radps: float = 0.0
    at_s: float | None = None


def steering_norm(report: SteeringReport | None) -> float:
    """The steering the robot has: measured if it can, else as commanded; 0 before any report."""
    if report is None:
        return 0.0
    return report.measured_norm if report.measured_valid else report.commanded_norm


def advance(
    pose: Pose,
    wheels: WheelSpeedReport,
    steering: SteeringReport | None,
    at_s: float,
    geometry: Geometry,
) -> Pose:
    """The pose after a wheel-speed report that arrived at `at_s` (midpoint heading); after one
    that measures no speed, the same position with no time and no velocities (unknown)."""
    if not wheels.measured_valid:
        return Pose(pose.x_m, pose.y_m, pose.yaw_rad)
    speed_mps = (wheels.left_mps + wheels.right_mps) / 2
    yaw_rate = yaw_rate_radps(speed_mps, steering_norm(steering), geometry)
    step_s = 0.0 if pose.at_s is None else at_s - pose.at_s
    if not 0.0 < step_s <= MAX_STEP_S:
        return Pose(pose.x_m, pose.y_m, pose.yaw_rad, speed_mps, yaw_rate, at_s)
    heading = pose.yaw_rad + yaw_rate * step_s / 2
    yaw = math.remainder(pose.yaw_rad + yaw_rate * step_s, math.tau)
    return Pose(
        pose.x_m + speed_mps * math.cos(heading) * step_s,
        pose.y_m + speed_mps * math.sin(heading) * step_s,
        yaw,
        speed_mps,
        yaw_rate,
        at_s,
    )
