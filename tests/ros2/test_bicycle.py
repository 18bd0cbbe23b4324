"""The bicycle model: signs as ROS and bywire write them, the round trip, full lock, and hold."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.hal.simulated.vehicle_model import VehicleConfig
from bywire.hal.simulated.vehicle_model import yaw_rate_radps as simulated_yaw_rate
from bywire.ros2.bicycle import steering_from_angle, steering_from_twist, yaw_rate_radps
from bywire.ros2.settings import Geometry

GEOMETRY = Geometry(wheelbase_m=0.8, max_steering_angle_rad=math.radians(30.0))
MIN_SPEED = 0.05


def test_a_left_turn_is_negative_steering() -> None:
    steering = steering_from_twist(1.0, 0.3, GEOMETRY, MIN_SPEED)
    assert steering is not None
    assert steering < 0.0
    assert steering_from_angle(math.radians(15.0), GEOMETRY) == pytest.approx(-0.5)


def test_reversing_with_a_left_yaw_steers_right() -> None:
    steering = steering_from_twist(-1.0, 0.3, GEOMETRY, MIN_SPEED)
    assert steering is not None
    assert steering > 0.0


def test_too_slow_to_tell_holds_the_steering() -> None:
    assert steering_from_twist(0.01, 0.5, GEOMETRY, MIN_SPEED) is None
    assert steering_from_twist(0.0, 0.5, GEOMETRY, MIN_SPEED) is None


def test_beyond_full_lock_is_full_lock_and_nonsense_is_straight() -> None:
    assert steering_from_angle(math.radians(80.0), GEOMETRY) == -1.0
    assert steering_from_angle(-math.radians(80.0), GEOMETRY) == 1.0
    assert steering_from_angle(math.nan, GEOMETRY) == 0.0
    assert steering_from_twist(1.0, math.inf, GEOMETRY, MIN_SPEED) is None


@given(
    speed=st.floats(0.1, 5.0) | st.floats(-5.0, -0.1),
    steering=st.floats(-0.99, 0.99),
)
def test_yaw_rate_and_steering_are_inverse(speed: float, steering: float) -> None:
    yaw_rate = yaw_rate_radps(speed, steering, GEOMETRY)
    back = steering_from_twist(speed, yaw_rate, GEOMETRY, MIN_SPEED)
    assert back == pytest.approx(steering, abs=1e-9)


@given(speed=st.floats(-3.0, 3.0), steering=st.floats(-1.0, 1.0))
def test_the_yaw_rate_is_the_simulated_vehicles(speed: float, steering: float) -> None:
    assert yaw_rate_radps(speed, steering, GEOMETRY) == pytest.approx(
        simulated_yaw_rate(speed, steering, VehicleConfig()), abs=1e-12
    )
