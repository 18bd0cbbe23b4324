"""Steering: normalised command to hobby-servo pulse, with rate limit and boosted set-point.

The servo takes 50 Hz PWM with 1…2 ms pulses (thesis §3.1.1). The trial run (§5.1.2) found the
servo sluggish and proposed a "boosted" set-point: add the error between set and current value to
the set value, so the servo is driven harder while it lags. Without a steering encoder the current
value is estimated from the servo's configured speed.

A handover is bumpless for the steering as for the throttle (R-SWITCH): when a source takes over
(RC to CAN, CAN to RC, or arming from STOP), the set-point moves to the new source's steering no
faster than `handover_rate_norm_per_s`, scaled down with speed (`handover_rate_norm_per_s`
below 1 m/s, a rate falling as 1/speed above it; without a trusted speed, the rate at the top
speed it is judged at, `HANDOVER_UNKNOWN_SPEED_MPS`) until it has reached it: switching to a
computer that asks for 0.9 at 1.6 m/s swung the servo by 0.71 of full lock within 0.5 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.values import slot_init


@dataclass(frozen=True, slots=True)
class SteeringConfig:
    """Servo calibration and dynamics; validated by `bywire.config`."""

    min_pulse_s: float = 0.0010
    center_pulse_s: float = 0.0015
    max_pulse_s: float = 0.0020
    reverse: bool = False
    rate_limit_norm_per_s: float = 4.0
    boost_gain: float = 0.0
    servo_speed_norm_per_s: float = 3.0
    handover_rate_norm_per_s: float = 0.5


@dataclass(frozen=True, slots=True)
class SteeringState:
    """Rate-limited set-point, estimated servo position, and when they were computed."""

    setpoint_norm: float = 0.0
    estimate_norm: float = 0.0
    updated_at: float | None = None
    blending: bool = False  # a source took over: the set-point moves at the handover rate

    def __init__(
        self,
        setpoint_norm: float = 0.0,
        estimate_norm: float = 0.0,
        updated_at: float | None = None,
        blending: bool = False,
    ) -> None:
        object.__setattr__(self, "setpoint_norm", setpoint_norm)
        object.__setattr__(self, "estimate_norm", estimate_norm)
        object.__setattr__(self, "updated_at", updated_at)
        object.__setattr__(self, "blending", blending)


slot_init(SteeringState)


def clamp_norm(value: float, low: float = -1.0, high: float = 1.0) -> float:
    """Clamp into [low, high]; NaN becomes 0 (centre), never a full deflection."""
    return 0.0 if math.isnan(value) else min(max(value, low), high)


def step_towards(current: float, target: float, max_step: float) -> float:
    """Move `current` towards `target` by at most `max_step` (≥ 0)."""
    return current + min(max(target - current, -max_step), max_step)


def pulse_for_steering(steering_norm: float, config: SteeringConfig) -> float:
    """−1 (full left) … 0 (centre) … 1 (full right) to a pulse width within min…max."""
    norm = clamp_norm(-steering_norm if config.reverse else steering_norm)
    if norm >= 0.0:
        return config.center_pulse_s + norm * (config.max_pulse_s - config.center_pulse_s)
    return config.center_pulse_s + norm * (config.center_pulse_s - config.min_pulse_s)


HANDOVER_FULL_RATE_MPS = 1.0
"""Below this speed a handover turns at its full rate; above it the rate falls as 1/speed."""
HANDOVER_UNKNOWN_SPEED_MPS = 3.0
"""The speed a handover assumes when the controller trusts no speed (the robot's top speed)."""


def handover_rate_norm_per_s(config: SteeringConfig, speed_mps: float | None) -> float:
    """How fast a handover may move the set-point at `speed_mps` (None: no trusted speed)."""
    speed = HANDOVER_UNKNOWN_SPEED_MPS if speed_mps is None else abs(speed_mps)
    scale = min(1.0, HANDOVER_FULL_RATE_MPS / speed) if speed > 0.0 else 1.0
    return min(config.rate_limit_norm_per_s, config.handover_rate_norm_per_s * scale)


def steering_step(
    state: SteeringState,
    target_norm: float,
    now: float,
    config: SteeringConfig,
    measured_norm: float | None = None,
    *,
    handover_speed_mps: float | None = None,
    handover: bool = False,
) -> tuple[SteeringState, float]:
    """One steering cycle: rate-limit the target, boost it, return the new state and pulse.

    `handover`: a source takes over now; until the set-point reaches the new target it moves at
    the handover rate for `handover_speed_mps` (None: no trusted speed)."""
    elapsed_s = 0.0 if state.updated_at is None else max(now - state.updated_at, 0.0)
    target = clamp_norm(target_norm)
    blending = state.blending or handover
    rate = (
        handover_rate_norm_per_s(config, handover_speed_mps)
        if blending
        else config.rate_limit_norm_per_s
    )
    setpoint = step_towards(state.setpoint_norm, target, rate * elapsed_s)
    estimate = step_towards(
        state.estimate_norm, state.setpoint_norm, config.servo_speed_norm_per_s * elapsed_s
    )
    current = estimate if measured_norm is None else clamp_norm(measured_norm)
    boosted = clamp_norm(setpoint + config.boost_gain * (setpoint - current))
    new_state = SteeringState(setpoint, estimate, now, blending and setpoint != target)
    return new_state, pulse_for_steering(boosted, config)
