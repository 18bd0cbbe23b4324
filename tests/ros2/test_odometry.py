"""Odometry from the reports: straight lines, circles of the bicycle's radius, gaps not bridged."""

from __future__ import annotations

import math

import pytest

from bywire.model import SteeringReport, WheelSpeedReport
from bywire.ros2.odometry import MAX_STEP_S, Pose, advance, steering_norm
from bywire.ros2.settings import Geometry

GEOMETRY = Geometry(wheelbase_m=0.8, max_steering_angle_rad=math.radians(30.0))
PERIOD_S = 0.02


def _drive(pose: Pose, speed: float, steering: SteeringReport | None, seconds: float) -> Pose:
    start = 0.0 if pose.at_s is None else pose.at_s
    for index in range(1, round(seconds / PERIOD_S) + 1):
        pose = advance(
            pose, WheelSpeedReport(speed, speed), steering, start + index * PERIOD_S, GEOMETRY
        )
    return pose


def test_straight_ahead_for_two_seconds_is_a_metre() -> None:
    pose = _drive(advance(Pose(), WheelSpeedReport(0.5, 0.5), None, 0.0, GEOMETRY), 0.5, None, 2.0)
    assert pose.x_m == pytest.approx(1.0)
    assert pose.y_m == pytest.approx(0.0)
    assert pose.speed_mps == 0.5


def test_a_full_circle_comes_back_to_the_start() -> None:
    steering = SteeringReport(commanded_norm=-0.5, measured_norm=0.0, measured_valid=False)
    start = advance(Pose(), WheelSpeedReport(1.0, 1.0), steering, 0.0, GEOMETRY)
    radius = GEOMETRY.wheelbase_m / math.tan(0.5 * GEOMETRY.max_steering_angle_rad)
    pose = _drive(start, 1.0, steering, 2 * math.pi * radius)
    assert pose.yaw_rate_radps > 0.0  # steering left turns left
    assert math.hypot(pose.x_m, pose.y_m) < 0.01


def test_the_measured_steering_wins_when_valid() -> None:
    assert steering_norm(SteeringReport(0.3, -0.2, True)) == -0.2
    assert steering_norm(SteeringReport(0.3, -0.2, False)) == 0.3
    assert steering_norm(None) == 0.0


def test_a_gap_is_not_bridged() -> None:
    pose = advance(Pose(), WheelSpeedReport(1.0, 1.0), None, 0.0, GEOMETRY)
    after = advance(pose, WheelSpeedReport(1.0, 1.0), None, MAX_STEP_S + 0.1, GEOMETRY)
    assert (after.x_m, after.y_m) == (0.0, 0.0)
    assert after.at_s == MAX_STEP_S + 0.1
