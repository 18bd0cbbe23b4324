r"""The speed governor: what keeps the robot under `[limits] max_speed_mps`; pure, takes `now`.

With a trusted wheel speed |v| and the limit L (docs/SAFETY.md row 67), in every driving mode:

    throttle cap                          governor brake
    1 -------\                            1                 /------
              \                                            /
    0          \__________                0 ______________/
       L - band  L                                L + margin  L + 2 margin      (speed ->)

- the cap is 1 below L − band and falls linearly to 0 at L: the throttle asked is reduced as the
  speed nears the limit (band: `band_mps`, a fifth of L, at least 0.1 m/s);
- the brake begins only once L is passed by the margin (`margin_mps`, a tenth of L, at least
  0.1 m/s) and grows linearly to full at L + 2·margin. A brake command is graded: regeneration
  from the first bit, the hydraulic brake above its threshold (`control.hydrobrake`). A small
  overshoot on a slope gets the brake it needs and no more; the governor never stops the robot;
- cap and brake each move at most `RATE_PER_S` per second (0 to full in 0.25 s): never a jerk.
  A cap coming down starts from no higher than the throttle asked (above it, it moves no
  output). The brake begins only once the cap has come down to 0 (a brake command cuts the
  throttle in `control.drive`).

Without a trusted speed (no sensor, a faulted one, or a standstill it has not proven:
`control.speed_check.trusted_speed`) there is nothing to govern on: the cap is the throttle
ceiling, the throttle that holds L on flat ground by the vehicle's calibration
(`[vehicle] flat_speeds_mps` / `flat_throttles`), and there is no brake. A ceiling, not a
governor: downhill the robot can pass L.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from bywire.control.mux import Movement
from bywire.control.values import slot_init

RATE_PER_S = 4.0
"""The fastest the cap or the brake moves, in full ranges per second (0 to 1 in 0.25 s)."""
BAND_FRACTION = 0.2
MARGIN_FRACTION = 0.1
LEAST_BAND_MPS = 0.1
LEAST_MARGIN_MPS = 0.1


@dataclass(frozen=True, slots=True)
class GovernorConfig:
    """The limit (None: no limit, the governor passes everything) and the throttle ceiling used
    without a trusted speed (`ceiling_throttle`)."""

    max_speed_mps: float | None = None
    ceiling_throttle_norm: float = 1.0

    @property
    def band_mps(self) -> float:
        return 0.0 if self.max_speed_mps is None else band_mps(self.max_speed_mps)

    @property
    def margin_mps(self) -> float:
        return 0.0 if self.max_speed_mps is None else margin_mps(self.max_speed_mps)


def band_mps(limit_mps: float) -> float:
    """Below the limit by this much, the throttle begins to be reduced."""
    return max(BAND_FRACTION * limit_mps, LEAST_BAND_MPS)


def margin_mps(limit_mps: float) -> float:
    """Above the limit by this much, the brake begins; full brake at twice it."""
    return max(MARGIN_FRACTION * limit_mps, LEAST_MARGIN_MPS)


def interpolate(xs: Sequence[float], ys: Sequence[float], x: float) -> float:
    """Piecewise linear through (xs, ys), xs rising; held flat beyond either end."""
    if x <= xs[0]:
        return ys[0]
    for index in range(1, len(xs)):
        if x <= xs[index]:
            x0, y0, x1, y1 = xs[index - 1], ys[index - 1], xs[index], ys[index]
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return ys[-1]


def ceiling_throttle(
    limit_mps: float, speeds_mps: Sequence[float], throttles: Sequence[float]
) -> float:
    """The throttle that holds `limit_mps` on flat ground by the calibration (speed → throttle);
    a limit beyond the calibrated speeds gets the last throttle, not full throttle."""
    return interpolate(speeds_mps, throttles, limit_mps)


@dataclass(frozen=True, slots=True)
class GovernorState:
    """The cap and brake as the previous step left them, and when; None: not driving."""

    cap_norm: float = 1.0
    brake_norm: float = 0.0
    at: float | None = None

    def __init__(
        self,
        cap_norm: float = 1.0,
        brake_norm: float = 0.0,
        at: float | None = None,
    ) -> None:
        object.__setattr__(self, "cap_norm", cap_norm)
        object.__setattr__(self, "brake_norm", brake_norm)
        object.__setattr__(self, "at", at)


slot_init(GovernorState)


IDLE = GovernorState()


def _targets(speed_mps: float | None, limit: float, ceiling_norm: float) -> tuple[float, float]:
    """The cap and brake the speed asks for (a ceiling and no brake without a speed)."""
    if speed_mps is None or math.isnan(speed_mps):
        return ceiling_norm, 0.0
    speed = abs(speed_mps)
    cap = min(max((limit - speed) / band_mps(limit), 0.0), 1.0)
    margin = margin_mps(limit)
    brake = min(max((speed - limit - margin) / margin, 0.0), 1.0)
    return cap, brake


def _towards(previous: float, target: float, step: float) -> float:
    return previous + min(max(target - previous, -step), step)


def governor_step(
    state: GovernorState,
    speed_mps: float | None,
    driving: bool,
    now: float,
    config: GovernorConfig,
    *,
    asked_throttle_norm: float = 1.0,
) -> GovernorState:
    """The cap and brake at `now` for the trusted speed `speed_mps` (signed; None: untrusted)
    and the throttle the robot is asked for (`asked_throttle_norm`, after the interlocks).
    Not driving, the governor forgets: an arming starts from the targets (its throttle starts
    from 0 at the interlock's slew anyway).

    A cap coming down starts from no higher than the throttle asked: above it, the cap holds
    nothing back, and lowering it there moves no output. (It once came down from 1 at the rate
    bound while the stick asked for 0: rolling downhill at a 0.1 m/s limit, the brake waited
    0.5 s for a cap that limited nothing, and the robot reached 0.53 m/s against a bound of
    0.3; `bywire verify --draw-robots`, seed 2, H11.)"""
    if config.max_speed_mps is None or not driving:
        return IDLE
    cap, brake = _targets(speed_mps, config.max_speed_mps, config.ceiling_throttle_norm)
    if state.at is None:
        return GovernorState(cap, brake if cap == 0.0 else 0.0, now)
    step = RATE_PER_S * max(now - state.at, 0.0)
    previous_cap = state.cap_norm
    if cap < previous_cap:
        previous_cap = min(previous_cap, max(asked_throttle_norm, cap))
    new_cap = _towards(previous_cap, cap, step)
    new_brake = _towards(state.brake_norm, brake if new_cap == 0.0 else 0.0, step)
    return GovernorState(new_cap, new_brake, now)


def governed(movement: Movement, state: GovernorState) -> Movement:
    """The movement with the governor's cap and brake applied: the throttle at most the cap, the
    brake at least the governor's (and then no throttle)."""
    if state.at is None:
        return movement
    brake = max(movement.brake_norm, state.brake_norm)
    throttle = 0.0 if state.brake_norm > 0.0 else min(movement.throttle_norm, state.cap_norm)
    return Movement(movement.steering_norm, throttle, brake, movement.gear)


def acting(movement: Movement, state: GovernorState) -> bool:
    """Whether the governor holds the throttle below what was asked, or brakes."""
    return state.at is not None and (
        state.brake_norm > 0.0 or movement.throttle_norm > state.cap_norm
    )
