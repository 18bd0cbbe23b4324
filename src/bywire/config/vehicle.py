"""The `[vehicle]` table: the robot's geometry, which the simulated vehicle moves by and which the
ROS 2 bridge (`bywire ros2`) turns curvature and steering angles into steering commands with; and
its drive's calibration, the throttle that holds each speed on flat ground, from which the speed
limit's throttle ceiling is derived when the wheel speed cannot be trusted (`control.governor`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from bywire.config.reader import Interval, Table

WHEELBASE_M = Interval(0.1, 10.0, "m")
TRACK_M = Interval(0.1, 5.0, "m")
STEERING_ANGLE_DEG = Interval(1.0, 60.0, "°")
FLAT_SPEED_MPS = Interval(0.0, 30.0, "m/s")
FLAT_THROTTLE = Interval(0.0, 1.0)
MAP_POINTS = range(2, 33)
SIM_FLAT_SPEEDS_MPS = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 2.9)
SIM_FLAT_THROTTLES = (0.125, 0.146, 0.176, 0.222, 0.3, 0.462, 0.811)
"""The simulated vehicle's calibration, read off `bywire.hal.simulated.vehicle_model` (a test
holds it to the model; the ROS 2 bridge's feed-forward map has the same numbers)."""


@dataclass(frozen=True, slots=True)
class VehicleSection:
    """Front-to-rear axle distance, wheel track, and the road-wheel angle at full steering (±1).

    The defaults are the simulated robot's (`bywire.hal.simulated.vehicle_model.VehicleConfig`).
    """

    wheelbase_m: float = 0.8
    track_m: float = 0.6
    max_steering_angle_deg: float = 30.0
    flat_speeds_mps: tuple[float, ...] = SIM_FLAT_SPEEDS_MPS
    flat_throttles: tuple[float, ...] = SIM_FLAT_THROTTLES

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
        flat_speeds_mps=table.number_list(
            "flat_speeds_mps", default.flat_speeds_mps, FLAT_SPEED_MPS, MAP_POINTS, strict=True
        ),
        flat_throttles=table.number_list(
            "flat_throttles", default.flat_throttles, FLAT_THROTTLE, MAP_POINTS, strict=False
        ),
    )
    if len(section.flat_speeds_mps) != len(section.flat_throttles):
        table.refuse(
            "flat_throttles",
            list(section.flat_throttles),
            f"one throttle for each of the {len(section.flat_speeds_mps)} flat_speeds_mps",
        )
        section = replace(section, flat_throttles=(1.0,) * len(section.flat_speeds_mps))
    table.close()
    return section
