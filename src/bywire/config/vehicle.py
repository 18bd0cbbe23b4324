"""The `[vehicle]` table: the robot's geometry, which the simulated vehicle moves by and which the
ROS 2 bridge (`bywire ros2`) turns curvature and steering angles into steering commands with."""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.config.reader import Interval, Table

WHEELBASE_M = Interval(0.1, 10.0, "m")
TRACK_M = Interval(0.1, 5.0, "m")
STEERING_ANGLE_DEG = Interval(1.0, 60.0, "°")


@dataclass(frozen=True, slots=True)
class VehicleSection:
    """Front-to-rear axle distance, wheel track, and the road-wheel angle at full steering (±1).

    The defaults are the simulated robot's (`bywire.hal.simulated.vehicle_model.VehicleConfig`).
    """

    wheelbase_m: float = 0.8
    track_m: float = 0.6
    max_steering_angle_deg: float = 30.0

    @property
    def max_steering_angle_rad(self) -> float:
        """The road-wheel angle at steering ±1, in radians."""
        return math.radians(self.max_steering_angle_deg)


def vehicle_section(table: Table) -> VehicleSection:
    default = VehicleSection()
    section = VehicleSection(
        wheelbase_m=table.number("wheelbase_m", default.wheelbase_m, WHEELBASE_M),
        track_m=table.number("track_m", default.track_m, TRACK_M),
        max_steering_angle_deg=table.number(
            "max_steering_angle_deg", default.max_steering_angle_deg, STEERING_ANGLE_DEG
        ),
    )
    table.close()
    return section
