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
            pose, WheelSpeedReport(speed, speed, True), steering, start + index * PERIOD_S, GEOMETRY
        )
    return pose


def test_straight_ahead_for_two_seconds_is_a_metre() -> None:
    pose = _drive(
        advance(Pose(), WheelSpeedReport(0.5, 0.5, True), None, 0.0, GEOMETRY), 0.5, None, 2.0
    )
    assert pose.x_m == pytest.approx(1.0)
    assert pose.y_m == pytest.approx(0.0)
    assert pose.speed_mps == 0.5


def test_a_full_circle_comes_back_to_the_start() -> None:
    steering = SteeringReport(commanded_norm=-0.5, measured_norm=0.0, measured_valid=False)
    start = advance(Pose(), WheelSpeedReport(1.0, 1.0, True), steering, 0.0, GEOMETRY)
    radius = GEOMETRY.wheelbase_m / math.tan(0.5 * GEOMETRY.max_steering_angle_rad)
    pose = _drive(start, 1.0, steering, 2 * math.pi * radius)
    assert pose.yaw_rate_radps > 0.0  # steering left turns left
    assert math.hypot(pose.x_m, pose.y_m) < 0.01


def test_the_measured_steering_wins_when_valid() -> None:
    assert steering_norm(SteeringReport(0.3, -0.2, True)) == -0.2
    assert steering_norm(SteeringReport(0.3, -0.2, False)) == 0.3
    assert steering_norm(None) == 0.0


def test_a_gap_is_not_bridged() -> None:
    pose = advance(Pose(), WheelSpeedReport(1.0, 1.0, True), None, 0.0, GEOMETRY)
    after = advance(pose, WheelSpeedReport(1.0, 1.0, True), None, MAX_STEP_S + 0.1, GEOMETRY)
    assert (after.x_m, after.y_m) == (0.0, 0.0)
    assert after.at_s == MAX_STEP_S + 0.1


def test_an_unmeasured_speed_is_not_integrated_as_standstill() -> None:
    """Row 60: the pose holds with no time (nothing is published from it) and integration starts
    again at the next measured report, without bridging the unmeasured stretch."""
    pose = advance(Pose(), WheelSpeedReport(1.0, 1.0, True), None, 0.0, GEOMETRY)
    pose = advance(pose, WheelSpeedReport(1.0, 1.0, True), None, 0.1, GEOMETRY)
    unknown = advance(pose, WheelSpeedReport(0.0, 0.0, False), None, 0.2, GEOMETRY)
    assert (unknown.x_m, unknown.yaw_rad, unknown.at_s) == (pose.x_m, pose.yaw_rad, None)
    again = advance(unknown, WheelSpeedReport(1.0, 1.0, True), None, 0.3, GEOMETRY)
    assert (again.x_m, again.at_s, again.speed_mps) == (pose.x_m, 0.3, 1.0)
