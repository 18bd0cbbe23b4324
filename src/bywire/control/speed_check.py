"""Plausibility of the wheel-speed sensor; pure, takes `now`.

The direction interlock trusts the measured speed to prove standstill, so a sensor that dies
quietly (drops to 0 while the robot rolls) would let it reverse at speed. Two checks catch it:

- the speed changes faster than the robot can brake or accelerate: more than
  `speed_max_change_mps2` × elapsed time + `speed_step_tolerance_mps` between two readings;
- the robot is driven (applied throttle ≥ `speed_stuck_throttle_norm`) for longer than
  `speed_stuck_s` and the sensor keeps reading standstill.

The loader holds the second check's two keys to a physical start (`config/deadlines.py`, 'a
start is no stuck sensor', docs/SAFETY.md row 81): on the flat, the robot driven at the
threshold passes `standstill_speed_mps` within `speed_stuck_s`, so a sound sensor is never taken
for a stuck one there; a threshold of 0 counted a standing robot as driven.

Either latches SPEED_SENSOR_FAULT: from then on the interlock gets no speed (its no-sensor rule,
the longer dwell with the brake held) until the next arming event clears the fault.

Neither catches a sensor that dies while the robot stands, before it is driven for
`speed_stuck_s`, nor one whose latched fault an arming event cleared while the robot still
rolled: in both it reads a standstill it has not seen. So a reading of standstill proves
standstill only once the sensor has earned it: it is *unproven* (the interlock gets no speed,
without a fault being raised) from any applied throttle, from a gap in its readings and from the
clearing of a fault, until it reads motion again. A working sensor reads motion within
milliseconds of the robot moving; a dead one never does, and the robot reverses only through the
no-sensor rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.interlocks import InterlockConfig, elapsed_since
from bywire.control.stop import STANDSTILL_LIMIT_MPS
from bywire.control.values import slot_init


@dataclass(frozen=True, slots=True)
class SpeedCheckState:
    """The last reading, since when the robot is driven without moving, the latched fault,
    whether a standstill the sensor reads is unproven (see the module's text), since when the
    readings say standstill, and whether they came to it abruptly: from a reading above
    `STANDSTILL_LIMIT_MPS`, or from no reading (a sensor dying inside its blind spot reads so;
    a controlled stop holds such a standstill before it ends, `control/stop.py`)."""

    previous_mps: float | None = None
    updated_at: float | None = None
    stuck_since: float | None = None
    faulted: bool = False
    unproven: bool = False
    standstill_since: float | None = None
    standstill_abrupt: bool = False

    def __init__(  # noqa: PLR0917
        self,
        previous_mps: float | None = None,
        updated_at: float | None = None,
        stuck_since: float | None = None,
        faulted: bool = False,
        unproven: bool = False,
        standstill_since: float | None = None,
        standstill_abrupt: bool = False,
    ) -> None:
        object.__setattr__(self, "previous_mps", previous_mps)
        object.__setattr__(self, "updated_at", updated_at)
        object.__setattr__(self, "stuck_since", stuck_since)
        object.__setattr__(self, "faulted", faulted)
        object.__setattr__(self, "unproven", unproven)
        object.__setattr__(self, "standstill_since", standstill_since)
        object.__setattr__(self, "standstill_abrupt", standstill_abrupt)


slot_init(SpeedCheckState)


def _jumped(state: SpeedCheckState, speed_mps: float, now: float, config: InterlockConfig) -> bool:
    if state.previous_mps is None:
        return False
    allowed = config.speed_max_change_mps2 * elapsed_since(state.updated_at, now)
    return abs(speed_mps - state.previous_mps) > allowed + config.speed_step_tolerance_mps


def speed_check_step(
    state: SpeedCheckState,
    speed_mps: float | None,
    applied_throttle_norm: float,
    now: float,
    config: InterlockConfig,
) -> SpeedCheckState:
    """The check after one reading (None: no sensor or no reading, nothing to check)."""
    if speed_mps is None:  # the robot may move unseen until the readings come back
        return SpeedCheckState(faulted=state.faulted, unproven=True)
    if not math.isfinite(speed_mps):
        return SpeedCheckState(faulted=True, unproven=True)
    moving = abs(speed_mps) > config.standstill_speed_mps
    still = applied_throttle_norm >= config.speed_stuck_throttle_norm and not moving
    stuck_since = (now if state.stuck_since is None else state.stuck_since) if still else None
    stuck = stuck_since is not None and now - stuck_since > config.speed_stuck_s
    faulted = state.faulted or stuck or _jumped(state, speed_mps, now, config)
    unproven = not moving and (state.unproven or applied_throttle_norm > 0.0)
    if moving:
        standstill_since, abrupt = None, False
    elif state.standstill_since is None:  # arriving at standstill: from how fast?
        previous = state.previous_mps
        standstill_since = now
        abrupt = previous is None or abs(previous) > STANDSTILL_LIMIT_MPS
    else:
        standstill_since, abrupt = state.standstill_since, state.standstill_abrupt
    return SpeedCheckState(speed_mps, now, stuck_since, faulted, unproven, standstill_since, abrupt)


def blind_spot_mps(config: InterlockConfig, period_s: float) -> float:
    """The fastest speed at which a sensor that dies (drops to 0) passes the jump check unseen
    between two readings `period_s` apart: it reads like a stop."""
    return config.speed_step_tolerance_mps + config.speed_max_change_mps2 * period_s


def trusted_speed(state: SpeedCheckState, speed_mps: float | None) -> float | None:
    """The speed the interlock may use: none once the sensor is faulted, nor while the
    standstill it reads is unproven."""
    return None if state.faulted or state.unproven else speed_mps


def cleared(state: SpeedCheckState) -> SpeedCheckState:
    """After an arming event: the fault acknowledged and checked afresh from the next reading;
    but a sensor that was faulted proves nothing until it reads motion again (the robot may be
    rolling at the arming, and a dead sensor reads standstill); a standstill that a sound sensor
    has read goes on counting."""
    if state.faulted or state.unproven:
        return SpeedCheckState(unproven=True)
    return SpeedCheckState(
        standstill_since=state.standstill_since, standstill_abrupt=state.standstill_abrupt
    )
