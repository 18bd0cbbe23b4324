"""The bridge's numbers (its ROS parameters), each range-checked, and the robot's geometry.

`BridgeSettings` holds every tunable value under the name of its ROS parameter. `settings_from`
builds it from parameter values and refuses a bad one with the parameter's name, the value and
the allowed range (a `ConfigError`, exit 2). The defaults fit the simulated robot: the
feed-forward map is the throttle that holds each speed on flat ground, and the brake map the
brake that gives each deceleration, both read off `bywire.hal.simulated.vehicle_model` (a test holds
them to it). A real robot measures its own: drive at a steady throttle, note the speed.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace

from bywire.config.reader import Interval
from bywire.config.vehicle import VehicleSection
from bywire.errors import ConfigError

STOP_RAMP_S = Interval(0.3, 0.5, "s")
INPUT_AGE_S = Interval(0.02, 2.0, "s")
GAIN = Interval(0.0, 20.0)
NORM = Interval(0.0, 1.0)
SPEED_MPS = Interval(0.0, 30.0, "m/s", low_open=True)
ACCEL_MPS2 = Interval(0.0, 20.0, "m/s²", low_open=True)
STANDSTILL_MPS = Interval(0.0, 1.0, "m/s", low_open=True)
ENABLE_TIMEOUT_S = Interval(0.1, 10.0, "s")
REPORT_TIMEOUT_S = Interval(0.05, 2.0, "s")
MAP_POINTS = range(2, 33)


@dataclass(frozen=True, slots=True)
class Geometry:
    """What the bicycle model needs of the robot: `[vehicle]` of its configuration."""

    wheelbase_m: float
    max_steering_angle_rad: float

    @classmethod
    def of(cls, vehicle: VehicleSection) -> Geometry:
        return cls(vehicle.wheelbase_m, vehicle.max_steering_angle_rad)


@dataclass(frozen=True, slots=True)
class BridgeSettings:
    """Every ROS parameter of the node that tunes its behaviour (docs/ROS2.md lists them)."""

    cmd_timeout_s: float = 0.2  # a command older than this since it arrived is not used
    max_stamp_age_s: float = 0.2  # ... nor one whose header stamp is older (or this far ahead)
    stop_ramp_s: float = 0.4  # a silent planner: standstill within this, from the timeout
    report_timeout_s: float = 0.2  # the robot's reports older than this: not driving
    enable_timeout_s: float = 1.0  # how long ~/enable waits for the robot to arm
    max_speed_mps: float = 2.0
    max_reverse_speed_mps: float = 0.8
    accel_limit_mps2: float = 0.8  # how fast the speed reference may rise
    decel_limit_mps2: float = 1.5  # how fast it may fall while the planner is live
    kp: float = 2.0  # throttle per m/s of speed error
    ki: float = 0.3  # throttle per m/s of error per second
    integral_limit: float = 0.3  # the integral's share of the throttle, at most
    brake_gain: float = 1.0  # brake per unit of negative loop output
    stop_kp: float = 1.0  # brake per m/s above the stop ramp
    standstill_speed_mps: float = 0.05
    hold_brake: float = 1.0  # the brake at standstill and while not enabled
    min_steering_speed_mps: float = 0.05  # below this a twist's curvature is undefined: hold
    feedforward_speeds_mps: tuple[float, ...] = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 2.9)
    feedforward_throttles: tuple[float, ...] = (0.125, 0.146, 0.176, 0.222, 0.3, 0.462, 0.811)
    brake_decels_mps2: tuple[float, ...] = (0.15, 0.9, 5.65)
    brake_norms: tuple[float, ...] = (0.0, 0.5, 1.0)


RANGES: dict[str, Interval] = {
    "cmd_timeout_s": INPUT_AGE_S,
    "max_stamp_age_s": INPUT_AGE_S,
    "stop_ramp_s": STOP_RAMP_S,
    "report_timeout_s": REPORT_TIMEOUT_S,
    "enable_timeout_s": ENABLE_TIMEOUT_S,
    "max_speed_mps": SPEED_MPS,
    "max_reverse_speed_mps": SPEED_MPS,
    "accel_limit_mps2": ACCEL_MPS2,
    "decel_limit_mps2": ACCEL_MPS2,
    "kp": GAIN,
    "ki": GAIN,
    "integral_limit": NORM,
    "brake_gain": GAIN,
    "stop_kp": GAIN,
    "standstill_speed_mps": STANDSTILL_MPS,
    "hold_brake": Interval(0.1, 1.0),
    "min_steering_speed_mps": STANDSTILL_MPS,
}
"""The allowed range of every number; the maps are checked by `_check_map`."""

MAPS = (
    ("feedforward_speeds_mps", "feedforward_throttles", Interval(0.0, 30.0, "m/s"), NORM),
    ("brake_decels_mps2", "brake_norms", Interval(0.0, 50.0, "m/s²"), NORM),
)
"""Each map: its x parameter (strictly rising), its y parameter (rising), and their ranges."""

DEFAULTS = BridgeSettings()
SHELL_PARAMETERS: dict[str, bool | str] = {
    "twist_stamped": True,
    "odom_frame_id": "odom",
    "base_frame_id": "base_link",
    "publish_tf": False,
}
"""The rclpy node's own parameters: the message type of cmd_vel, odometry's frames, TF."""


def parameter_defaults() -> dict[str, float | tuple[float, ...]]:
    """Every parameter with its default, for the node to declare."""
    return {field.name: getattr(DEFAULTS, field.name) for field in fields(BridgeSettings)}


def capped_by(settings: BridgeSettings, robot_limit_mps: float | None) -> BridgeSettings:
    """The settings with their speed gates (`max_speed_mps`, `max_reverse_speed_mps`: what a
    cmd_vel or a speed request is clamped to) no faster than the robot's own speed limit
    (`[limits] max_speed_mps`, docs/SAFETY.md row 67; None: none). The controller enforces the
    limit whatever the bridge asks; capped here, the bridge's speed loop aims at a speed it may
    reach instead of winding up against the governor."""
    if robot_limit_mps is None:
        return settings
    return replace(
        settings,
        max_speed_mps=min(settings.max_speed_mps, robot_limit_mps),
        max_reverse_speed_mps=min(settings.max_reverse_speed_mps, robot_limit_mps),
    )


def settings_from(values: Mapping[str, object]) -> BridgeSettings:
    """The settings from parameter values (missing ones take their default); ConfigError names
    the first bad parameter, its value and what is allowed."""
    unknown = sorted(set(values) - set(parameter_defaults()))
    if unknown:
        raise ConfigError(f"unknown parameter {unknown[0]}")
    numbers: dict[str, float] = {}
    vectors: dict[str, tuple[float, ...]] = {}
    for name, default in parameter_defaults().items():
        value = values.get(name, default)
        if isinstance(default, tuple):
            vectors[name] = _vector(name, value)
        else:
            numbers[name] = _number(name, value)
    for x_name, y_name, x_range, y_range in MAPS:
        _check_map((x_name, vectors[x_name]), (y_name, vectors[y_name]), x_range, y_range)
    return BridgeSettings(**numbers, **vectors)  # type: ignore[arg-type]


def _number(name: str, value: object) -> float:
    allowed = RANGES[name]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"parameter {name} = {value!r}: expected a number, {allowed}")
    if float(value) not in allowed:
        raise ConfigError(f"parameter {name} = {value!r}: out of range, allowed {allowed}")
    return float(value)


def _vector(name: str, value: object) -> tuple[float, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ConfigError(f"parameter {name} = {value!r}: expected an array of numbers")
    numbers = tuple(value)
    if not all(isinstance(item, int | float) and not isinstance(item, bool) for item in numbers):
        raise ConfigError(f"parameter {name} = {list(numbers)!r}: expected numbers only")
    return tuple(float(item) for item in numbers)


def _check_map(
    x_map: tuple[str, tuple[float, ...]],
    y_map: tuple[str, tuple[float, ...]],
    x_range: Interval,
    y_range: Interval,
) -> None:
    (x_name, xs), (y_name, ys) = x_map, y_map
    if len(xs) != len(ys) or len(xs) not in MAP_POINTS:
        raise ConfigError(
            f"parameters {x_name} and {y_name}: {len(xs)} and {len(ys)} points; they must have"
            f" the same number of points, {MAP_POINTS.start}..{MAP_POINTS[-1]}"
        )
    for name, points, allowed in ((x_name, xs, x_range), (y_name, ys, y_range)):
        bad = [point for point in points if point not in allowed or not math.isfinite(point)]
        if bad:
            raise ConfigError(f"parameter {name}: {bad[0]!r} out of range, allowed {allowed}")
    if any(b <= a for a, b in itertools.pairwise(xs)):
        raise ConfigError(f"parameter {x_name} = {list(xs)!r}: must rise strictly")
    if any(b < a for a, b in itertools.pairwise(ys)):
        raise ConfigError(f"parameter {y_name} = {list(ys)!r}: must not fall")


def interpolate(xs: Sequence[float], ys: Sequence[float], x: float) -> float:
    """Piecewise-linear y at x, held at the ends (a map, never extrapolated)."""
    if x <= xs[0]:
        return ys[0]
    for x0, x1, y0, y1 in zip(xs, xs[1:], ys, ys[1:], strict=False):
        if x <= x1:
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return ys[-1]
