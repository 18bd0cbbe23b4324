"""Interlocks between the selected set-point and the drive (R-INTERLOCK); pure, takes `now`.

`interlock_step` applies these rules, in this order; each one can only make the command safer:

1. Clamp in command units: a NaN or infinite value becomes its safe value (throttle 0, brake 1,
   steering held where it was); finite values are clamped to steering −1…1, throttle and brake 0…1.
2. Brake beats throttle: any brake above zero forces the throttle to zero.
3. Direction change only near standstill. A request for FORWARD or REVERSE *reverses* when the last
   direction applied was the other one (also with NEUTRAL in between), or when the measured speed
   says the robot moves the other way faster than the standstill threshold. A reversal is held
   back — the applied gear stays as it was, throttle 0 — until the robot has been *settled* for
   the dwell: requested throttle zero and |speed| ≤ `standstill_speed_mps`, both continuously,
   for `direction_dwell_s`. Without a speed measurement (None, NaN, or a sensor the speed check
   distrusts) the robot counts as settled only after zero requested throttle *with the brake at
   `unknown_speed_brake_norm` or more* for `unknown_speed_dwell_s`: waiting alone proves nothing
   of a robot that coasts (rolling drag stops it from 2 m/s in ~13 s), braking does (at 0.8 the
   regenerative and hydraulic brakes give ~3.6 m/s², 5 m/s in the 1.5 s). NEUTRAL is always
   granted at once: it only removes drive. In NEUTRAL the throttle is zero.
4. Throttle slew: the applied throttle rises by at most `throttle_slew_up_per_s` per second of
   `now` and may always fall at once (falling is the safe direction). Steering slew is
   steering.py's, not repeated here.

So the applied throttle never exceeds the clamped requested throttle; every output is in range.

Before them, `can_throttle_allowed` (issue 41 finding 6): in CAN mode no throttle is taken while
the speed check has SPEED_SENSOR_FAULT latched. A computer that drives on the wheel speed it
reads sees a dead sensor's 0 m/s and opens the throttle (the ROS 2 bridge did: 2.36 m/s after 8 s
and rising); the controller cannot know whether the computer has another speed source, and zero
is the only ceiling that bounds the speed without a measurement. It is no stop: the computer may
still brake and steer, RC is unaffected, and the next arming (through STOP) clears the fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.mux import Movement
from bywire.control.values import slot_init
from bywire.model import ControlMode, Gear

# Without a speed sensor the dwell cannot prove standstill; 1.5 s is about what full regenerative
# braking (≈ 1.5 m/s²) needs to stop the robot from walking pace (≈ 2 m/s), a plausible pace when
# an operator flips direction. Fit a wheel-speed sensor for the real check.
UNKNOWN_SPEED_DWELL_S = 1.5


@dataclass(frozen=True, slots=True)
class InterlockConfig:
    """Thresholds of the interlocks; every value must be finite and ≥ 0 (slew > 0)."""

    standstill_speed_mps: float = 0.05
    direction_dwell_s: float = 0.5
    unknown_speed_dwell_s: float = UNKNOWN_SPEED_DWELL_S
    unknown_speed_brake_norm: float = 0.8
    throttle_slew_up_per_s: float = 1.0
    # Plausibility of the speed sensor (`bywire.control.speed_check`): the robot brakes at most
    # ~11.7 m/s² with every brake on and accelerates at 1.2 m/s², so 15 m/s² is never real.
    speed_max_change_mps2: float = 15.0
    speed_step_tolerance_mps: float = 0.3
    speed_stuck_throttle_norm: float = 0.3
    speed_stuck_s: float = 1.0

    def __post_init__(self) -> None:
        limits = (
            self.standstill_speed_mps,
            self.direction_dwell_s,
            self.unknown_speed_dwell_s,
            self.unknown_speed_brake_norm,
            self.speed_max_change_mps2,
            self.speed_step_tolerance_mps,
            self.speed_stuck_throttle_norm,
            self.speed_stuck_s,
        )
        if not all(math.isfinite(value) and value >= 0.0 for value in limits):
            raise ValueError("standstill speed, dwells and speed-check limits must be finite, >= 0")
        if not (math.isfinite(self.throttle_slew_up_per_s) and self.throttle_slew_up_per_s > 0.0):
            raise ValueError("throttle_slew_up_per_s must be finite and > 0")


@dataclass(frozen=True, slots=True)
class InterlockState:
    """What the interlocks remember: the applied command and since when the robot is settled.

    `direction` is the last FORWARD or REVERSE applied (NEUTRAL if none yet). `quiet_since` starts
    a run of zero requested throttle with speed at standstill, or unknown and the brake applied;
    `standstill_since` a run of zero requested throttle with a *measured* speed at standstill.
    """

    gear: Gear = Gear.NEUTRAL
    direction: Gear = Gear.NEUTRAL
    quiet_since: float | None = None
    standstill_since: float | None = None
    throttle_norm: float = 0.0
    steering_norm: float = 0.0
    updated_at: float | None = None

    def __init__(  # noqa: PLR0917
        self,
        gear: Gear = Gear.NEUTRAL,
        direction: Gear = Gear.NEUTRAL,
        quiet_since: float | None = None,
        standstill_since: float | None = None,
        throttle_norm: float = 0.0,
        steering_norm: float = 0.0,
        updated_at: float | None = None,
    ) -> None:
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "direction", direction)
        object.__setattr__(self, "quiet_since", quiet_since)
        object.__setattr__(self, "standstill_since", standstill_since)
        object.__setattr__(self, "throttle_norm", throttle_norm)
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "updated_at", updated_at)


slot_init(InterlockState)


def _finite_clamp(value: float, low: float, high: float, safe: float) -> float:
    return min(max(value, low), high) if math.isfinite(value) else safe


def _since(since: float | None, condition: bool, now: float) -> float | None:
    return (now if since is None else since) if condition else None


def _opposite(gear: Gear) -> Gear:
    return {Gear.FORWARD: Gear.REVERSE, Gear.REVERSE: Gear.FORWARD}.get(gear, Gear.NEUTRAL)


def _reverses(state: InterlockState, gear: Gear, speed_mps: float | None, threshold: float) -> bool:
    """Whether applying `gear` would drive against the robot's last or measured direction."""
    if gear is Gear.NEUTRAL or gear is state.gear:
        return False
    sign = 1.0 if gear is Gear.FORWARD else -1.0
    moving_against = speed_mps is not None and sign * speed_mps < -threshold
    return state.direction is _opposite(gear) or moving_against


def _settled(
    quiet_since: float | None, standstill_since: float | None, now: float, config: InterlockConfig
) -> bool:
    """Settled for the dwell: measured standstill for the short one, or quiet for the long one."""
    measured = standstill_since is not None and now - standstill_since >= config.direction_dwell_s
    unmeasured = quiet_since is not None and now - quiet_since >= config.unknown_speed_dwell_s
    return measured or unmeasured


def _timers(
    state: InterlockState,
    wanted: Movement,
    speed_mps: float | None,
    now: float,
    config: InterlockConfig,
) -> tuple[float | None, float | None]:
    slow = speed_mps is not None and abs(speed_mps) <= config.standstill_speed_mps
    braking = wanted.brake_norm >= config.unknown_speed_brake_norm
    quiet = wanted.throttle_norm == 0.0 and (slow or (speed_mps is None and braking))
    standstill = wanted.throttle_norm == 0.0 and slow
    return _since(state.quiet_since, quiet, now), _since(state.standstill_since, standstill, now)


def _sanitised(requested: Movement, held_steering_norm: float) -> Movement:
    """Rule 1: non-finite values to their safe values, the rest clamped to range."""
    return Movement(
        steering_norm=_finite_clamp(requested.steering_norm, -1.0, 1.0, held_steering_norm),
        throttle_norm=_finite_clamp(requested.throttle_norm, 0.0, 1.0, 0.0),
        brake_norm=_finite_clamp(requested.brake_norm, 0.0, 1.0, 1.0),
        gear=requested.gear,
    )


def elapsed_since(updated_at: float | None, now: float) -> float:
    """Time since `updated_at`; 0 on the first step and when the clock is NaN or went backwards."""
    elapsed = 0.0 if updated_at is None else now - updated_at
    return elapsed if elapsed > 0.0 else 0.0


def _slewed(state: InterlockState, throttle_norm: float, now: float, slew_per_s: float) -> float:
    """Rule 4: rise by at most `slew_per_s` per second since the last step; fall at once."""
    elapsed_s = elapsed_since(state.updated_at, now)
    return min(throttle_norm, state.throttle_norm + slew_per_s * elapsed_s)


def interlock_step(
    state: InterlockState,
    requested: Movement,
    speed_mps: float | None,
    now: float,
    config: InterlockConfig,
) -> tuple[InterlockState, Movement, bool]:
    """Apply the interlocks to `requested` at `now`; `speed_mps` is signed, positive forward.

    Returns the new state, the movement that may reach the drive, and whether a direction change
    is being held back. Pure: reads no clock; a `now` earlier than the last one, or NaN, counts
    as no time.
    """
    wanted = _sanitised(requested, state.steering_norm)
    speed = None if speed_mps is None or math.isnan(speed_mps) else speed_mps
    limit = config.standstill_speed_mps
    quiet_since, standstill_since = _timers(state, wanted, speed, now, config)
    settled = _settled(quiet_since, standstill_since, now, config)
    held = _reverses(state, wanted.gear, speed, limit) and not settled
    gear = state.gear if held else wanted.gear
    blocked = held or wanted.brake_norm > 0.0 or gear is Gear.NEUTRAL
    throttle = (
        0.0 if blocked else _slewed(state, wanted.throttle_norm, now, config.throttle_slew_up_per_s)
    )
    direction = state.direction if gear is Gear.NEUTRAL else gear
    applied = Movement(wanted.steering_norm, throttle, wanted.brake_norm, gear)
    new_state = InterlockState(
        gear, direction, quiet_since, standstill_since, throttle, applied.steering_norm, now
    )
    return new_state, applied, held


def can_throttle_allowed(mode: ControlMode, speed_faulted: bool) -> bool:
    """Whether the commanding source's throttle may be taken: not in CAN mode while the speed
    check has SPEED_SENSOR_FAULT latched (see the module's text)."""
    return not (speed_faulted and mode is ControlMode.CAN)
