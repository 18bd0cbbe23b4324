"""The speed loop: a target speed to throttle, brake and gear, by a feed-forward map plus a PI
controller on the speed the robot reports. Pure; the caller gives the period.

    target ──rate limits──▶ reference ──┬─ feed-forward map(reference) ─┐
                                        └─ kp·error + ∫ki·error ────────┴─▶ u
    u ≥ 0: throttle u, no brake          u < 0: no throttle, brake −u·brake_gain

Speeds are handled as magnitudes in the direction of the gear. A change of direction first stops
the robot (the reference goes to 0 while the old gear is kept, never with throttle) and changes
gear at standstill;
the controller's own interlock then waits its dwell. At a zero target and standstill the robot is
held with `hold_brake`. Against wind-up (the controller slews its throttle, and the robot lags
behind a rising reference): the reference runs at most `MAX_LEAD_MPS` ahead of the robot, the
integral learns only within `INTEGRATE_BELOW_MPS` of it and while the output is not saturated,
and it is clamped to `integral_limit`.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.model import Gear
from bywire.ros2.settings import BridgeSettings, interpolate

MAX_LEAD_MPS = 0.25  # the reference runs at most this far ahead of the robot
INTEGRATE_BELOW_MPS = 0.05  # the integral learns only near the reference, not while catching up


@dataclass(frozen=True, slots=True)
class Pedals:
    """What goes into a movement command besides steering."""

    throttle_norm: float
    brake_norm: float
    gear: Gear


@dataclass(frozen=True, slots=True)
class LoopState:
    """The rate-limited reference (a magnitude in the gear's direction), the integral, the gear."""

    reference_mps: float = 0.0
    integral: float = 0.0
    gear: Gear = Gear.NEUTRAL

    def reset(self, measured_mps: float) -> LoopState:
        """Start again from the robot's speed: no integral, the reference where the robot is."""
        return LoopState(max(0.0, _sign(self.gear) * measured_mps), 0.0, self.gear)


def hold(state: LoopState, settings: BridgeSettings) -> Pedals:
    """Standing still, or not driving: no throttle, the holding brake."""
    return Pedals(0.0, settings.hold_brake, state.gear)


def _sign(gear: Gear) -> float:
    return -1.0 if gear is Gear.REVERSE else 1.0


def _wanted_gear(target_mps: float, current: Gear) -> Gear:
    if target_mps > 0.0:
        return Gear.FORWARD
    if target_mps < 0.0:
        return Gear.REVERSE
    return current


def _toward(value: float, goal: float, up_step: float, down_step: float) -> float:
    if goal > value:
        return min(goal, value + up_step)
    return max(goal, value - down_step)


def speed_step(
    state: LoopState,
    target_mps: float,
    measured_mps: float,
    dt_s: float,
    settings: BridgeSettings,
) -> tuple[LoopState, Pedals]:
    """One period of the loop: the next state and the pedals for this period."""
    target_mps = min(max(target_mps, -settings.max_reverse_speed_mps), settings.max_speed_mps)
    still = abs(measured_mps) <= settings.standstill_speed_mps
    gear = _wanted_gear(target_mps, state.gear)
    turning_back = False
    if gear is not state.gear:
        if state.gear is not Gear.NEUTRAL and not still:
            gear, target_mps, turning_back = state.gear, 0.0, True  # stop first, in the old gear
        else:
            state = LoopState(0.0, 0.0, gear)
    sign = _sign(gear)
    goal_mps = max(0.0, sign * target_mps)
    measured = sign * measured_mps
    reference = _toward(
        state.reference_mps,
        goal_mps,
        settings.accel_limit_mps2 * dt_s,
        settings.decel_limit_mps2 * dt_s,
    )
    reference = min(reference, max(measured, 0.0) + MAX_LEAD_MPS)
    if goal_mps == 0.0 and reference == 0.0 and still:
        held = LoopState(0.0, 0.0, gear)
        return held, hold(held, settings)
    error = reference - measured
    feedforward = (
        interpolate(settings.feedforward_speeds_mps, settings.feedforward_throttles, reference)
        if reference > 0.0
        else 0.0
    )
    output = feedforward + settings.kp * error + state.integral
    integral = state.integral
    saturated = (output >= 1.0 and error > 0.0) or (output <= -1.0 and error < 0.0)
    if not saturated and abs(error) < INTEGRATE_BELOW_MPS:
        limit = settings.integral_limit
        integral = min(max(integral + settings.ki * error * dt_s, -limit), limit)
    next_state = LoopState(reference, integral, gear)
    if turning_back:
        return next_state, Pedals(0.0, min(max(-output, 0.0) * settings.brake_gain, 1.0), gear)
    if output >= 0.0:
        return next_state, Pedals(min(output, 1.0), 0.0, gear)
    return next_state, Pedals(0.0, min(-output * settings.brake_gain, 1.0), gear)
