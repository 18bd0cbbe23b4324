"""The robot's longitudinal dynamics, steering servo and bicycle kinematics as pure step functions.

Sign conventions: speed is positive forward and negative in reverse; steering −1 is full left and
+1 full right (as in ``MovementCommand``); heading is counter-clockwise from the x axis, so a
left turn has a positive yaw rate. The model is deliberately simple, made to check a controller,
not a vehicle: accelerations, not forces, and every brake acts as a constant deceleration that
opposes motion and never reverses it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from bywire.control.values import slot_init


@dataclass(frozen=True, slots=True)
class VehicleConfig:
    """Constants of a small four-wheeled delivery robot like "Albert" (estimates, not measured).

    Drive: ``max_drive_accel_mps2`` at full throttle (``full_scale_volts``) from standstill,
    tapering linearly with speed so that full throttle on flat ground settles at the top speed
    of the driving direction (where drive equals rolling drag). Resistances, each a
    constant deceleration: rolling drag (c_rr ≈ 0.015 × g), regenerative braking at full
    scale (only while the motor controllers are enabled), the hydraulic brake at duty 1, and the
    spring-applied emergency brake. Steering: bicycle model; the servo turns at
    ``servo_rate_norm_per_s`` towards the position its pulse asks for.
    """

    full_scale_volts: float = 5.0
    max_drive_accel_mps2: float = 1.2
    top_speed_mps: float = 3.0
    reverse_top_speed_mps: float = 1.0
    rolling_drag_mps2: float = 0.15
    max_regen_decel_mps2: float = 1.5
    max_hydraulic_decel_mps2: float = 4.0
    ebrake_decel_mps2: float = 6.0
    wheelbase_m: float = 0.8
    track_m: float = 0.6
    max_steering_angle_rad: float = math.radians(30.0)
    servo_rate_norm_per_s: float = 1.5
    servo_min_pulse_s: float = 0.0010
    servo_center_pulse_s: float = 0.0015
    servo_max_pulse_s: float = 0.0020

    def __post_init__(self) -> None:
        if not 0.0 <= self.rolling_drag_mps2 < self.max_drive_accel_mps2:
            raise ValueError("rolling_drag_mps2 must be >= 0 and below max_drive_accel_mps2")
        lengths = (self.top_speed_mps, self.reverse_top_speed_mps, self.wheelbase_m, self.track_m)
        if min(lengths) <= 0.0 or self.full_scale_volts <= 0.0:
            raise ValueError("speeds, lengths and full_scale_volts must be > 0")


@dataclass(frozen=True, slots=True)
class ActuatorInputs:
    """What the actuators receive: Table 2's signals, the e-brake line and the two PWM outputs."""

    throttle_volts: float = 0.0
    regen_volts: float = 0.0
    motors_enable: bool = False
    motors_forward: bool = False
    motors_reverse: bool = False
    ebrake_release: bool = False
    hydraulic_duty: float = 0.0
    steering_pulse_s: float = 0.0

    def __init__(  # noqa: PLR0917
        self,
        throttle_volts: float = 0.0,
        regen_volts: float = 0.0,
        motors_enable: bool = False,
        motors_forward: bool = False,
        motors_reverse: bool = False,
        ebrake_release: bool = False,
        hydraulic_duty: float = 0.0,
        steering_pulse_s: float = 0.0,
    ) -> None:
        object.__setattr__(self, "throttle_volts", throttle_volts)
        object.__setattr__(self, "regen_volts", regen_volts)
        object.__setattr__(self, "motors_enable", motors_enable)
        object.__setattr__(self, "motors_forward", motors_forward)
        object.__setattr__(self, "motors_reverse", motors_reverse)
        object.__setattr__(self, "ebrake_release", ebrake_release)
        object.__setattr__(self, "hydraulic_duty", hydraulic_duty)
        object.__setattr__(self, "steering_pulse_s", steering_pulse_s)


slot_init(ActuatorInputs)


@dataclass(frozen=True, slots=True)
class VehicleState:
    """Where the robot is and how it moves; ``distance_m`` counts both directions."""

    speed_mps: float = 0.0
    steering_norm: float = 0.0
    x_m: float = 0.0
    y_m: float = 0.0
    heading_rad: float = 0.0
    yaw_rate_radps: float = 0.0
    distance_m: float = 0.0

    def __init__(  # noqa: PLR0917
        self,
        speed_mps: float = 0.0,
        steering_norm: float = 0.0,
        x_m: float = 0.0,
        y_m: float = 0.0,
        heading_rad: float = 0.0,
        yaw_rate_radps: float = 0.0,
        distance_m: float = 0.0,
    ) -> None:
        object.__setattr__(self, "speed_mps", speed_mps)
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "x_m", x_m)
        object.__setattr__(self, "y_m", y_m)
        object.__setattr__(self, "heading_rad", heading_rad)
        object.__setattr__(self, "yaw_rate_radps", yaw_rate_radps)
        object.__setattr__(self, "distance_m", distance_m)


slot_init(VehicleState)


def _unit(value: float) -> float:
    return 0.0 if math.isnan(value) else min(max(value, 0.0), 1.0)


def drive_accel_mps2(speed_mps: float, inputs: ActuatorInputs, config: VehicleConfig) -> float:
    """Signed drive acceleration: only when enabled with exactly one direction line set."""
    if not inputs.motors_enable or inputs.motors_forward == inputs.motors_reverse:
        return 0.0
    direction = 1.0 if inputs.motors_forward else -1.0
    top_speed_mps = config.top_speed_mps if inputs.motors_forward else config.reverse_top_speed_mps
    throttle = _unit(inputs.throttle_volts / config.full_scale_volts)
    # The drive would fade out at this speed; drag takes the rest, leaving top_speed_mps.
    fade_speed_mps = top_speed_mps / (1.0 - config.rolling_drag_mps2 / config.max_drive_accel_mps2)
    taper = min(max(1.0 - direction * speed_mps / fade_speed_mps, 0.0), 1.0)
    return direction * config.max_drive_accel_mps2 * throttle * taper


def resistance_mps2(inputs: ActuatorInputs, config: VehicleConfig) -> float:
    """Total deceleration magnitude of drag and every brake."""
    regen = _unit(inputs.regen_volts / config.full_scale_volts) if inputs.motors_enable else 0.0
    ebrake = 0.0 if inputs.ebrake_release else config.ebrake_decel_mps2
    return (
        config.rolling_drag_mps2
        + regen * config.max_regen_decel_mps2
        + _unit(inputs.hydraulic_duty) * config.max_hydraulic_decel_mps2
        + ebrake
    )


GRAVITY_MPS2 = 9.81


def grade_accel_mps2(grade: float) -> float:
    """Gravity along the road for a grade (rise over run, positive uphill when driving forward):
    it pulls the robot back uphill, −g·sin(atan(grade))."""
    return -GRAVITY_MPS2 * grade / math.sqrt(1.0 + grade * grade)


def speed_step(speed_mps: float, drive_mps2: float, resistance: float, dt_s: float) -> float:
    """Next speed: resistance opposes motion, holds a robot at rest, and stops it at zero."""
    if speed_mps == 0.0:
        excess = abs(drive_mps2) - resistance
        return math.copysign(excess * dt_s, drive_mps2) if excess > 0.0 else 0.0
    new_speed_mps = speed_mps + (drive_mps2 - math.copysign(resistance, speed_mps)) * dt_s
    # Compare signs, not the product: for a tiny speed the product underflows to −0.0.
    crossed_zero = (new_speed_mps > 0.0) != (speed_mps > 0.0)
    return 0.0 if crossed_zero else new_speed_mps


def servo_target_norm(pulse_s: float, current_norm: float, config: VehicleConfig) -> float:
    """The position a pulse asks for, −1…1; with no pulses (0 s) the servo stays put."""
    if pulse_s <= 0.0 or math.isnan(pulse_s):
        return current_norm
    centre_s = config.servo_center_pulse_s
    if pulse_s >= centre_s:
        norm = (pulse_s - centre_s) / (config.servo_max_pulse_s - centre_s)
    else:
        norm = (pulse_s - centre_s) / (centre_s - config.servo_min_pulse_s)
    return min(max(norm, -1.0), 1.0)


def servo_step(current_norm: float, target_norm: float, max_step_norm: float) -> float:
    """Move towards the target by at most ``max_step_norm``."""
    return current_norm + min(max(target_norm - current_norm, -max_step_norm), max_step_norm)


def yaw_rate_radps(speed_mps: float, steering_norm: float, config: VehicleConfig) -> float:
    """Bicycle model: v · tan(δ) / wheelbase, with δ positive (left) for steering −1."""
    angle_rad = -steering_norm * config.max_steering_angle_rad
    return speed_mps * math.tan(angle_rad) / config.wheelbase_m


def wheel_speeds_mps(state: VehicleState, config: VehicleConfig) -> tuple[float, float]:
    """(left, right): the outer wheel of a turn runs faster by yaw rate × track."""
    half_difference = state.yaw_rate_radps * config.track_m / 2.0
    return state.speed_mps - half_difference, state.speed_mps + half_difference


@dataclass(frozen=True, slots=True)
class VehicleModel:
    """The pure model with its constants: ``step(state, inputs, dt_s)`` gives the next state."""

    config: VehicleConfig = field(default_factory=VehicleConfig)

    def step(
        self, state: VehicleState, inputs: ActuatorInputs, dt_s: float, grade: float = 0.0
    ) -> VehicleState:
        """Advance ``dt_s`` with the actuators held at ``inputs`` (semi-implicit Euler), on a road
        of ``grade`` (rise over run in the forward direction; gravity acts like a drive that the
        brakes hold against, so a braked robot stays put on a slope they can hold)."""
        config = self.config
        target_norm = servo_target_norm(inputs.steering_pulse_s, state.steering_norm, config)
        steering = servo_step(state.steering_norm, target_norm, config.servo_rate_norm_per_s * dt_s)
        drive = drive_accel_mps2(state.speed_mps, inputs, config)
        if grade:  # on the flat the sum is left alone: the same floats as before grades
            drive += grade_accel_mps2(grade)
        speed = speed_step(state.speed_mps, drive, resistance_mps2(inputs, config), dt_s)
        yaw_rate = yaw_rate_radps(speed, steering, config)
        heading = state.heading_rad + yaw_rate * dt_s
        return VehicleState(
            speed_mps=speed,
            steering_norm=steering,
            x_m=state.x_m + speed * math.cos(heading) * dt_s,
            y_m=state.y_m + speed * math.sin(heading) * dt_s,
            heading_rad=heading,
            yaw_rate_radps=yaw_rate,
            distance_m=state.distance_m + abs(speed) * dt_s,
        )

    def wheel_speeds(self, state: VehicleState) -> tuple[float, float]:
        """(left_mps, right_mps) of a state."""
        return wheel_speeds_mps(state, self.config)
