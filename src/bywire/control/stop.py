"""Stop categories (IEC 60204-1 §9.2.2, ISO 13850): how the robot stops follows from why
(R-STOP-CATEGORY).

- **Category 0, `POWER_OFF`**: power is removed from the drive at once (enable low, 0 V), the
  spring brake engages and the hydraulic brake goes to full duty. For a drive that is itself
  suspect (DAC writes failing or too slow, the loop missing its deadlines, the watchdog): a drive
  that may not do what it is told must not be powered.
- **Category 1, `CONTROLLED`**: the drive stays powered to brake. Throttle 0 V at once, the
  regenerative brake at full, the hydraulic brake at full duty, the spring brake engaged; the
  enable line goes low at standstill (a trusted speed at or below the standstill threshold; one
  the readings dropped to abruptly held for `StopConfig.standstill_hold_s`), after
  `StopConfig.controlled_max_s` at the latest, or at once when the robot does not slow down as
  a braking robot must (then category 0 after all: `escalated`, flag STOP_ESCALATED). For
  every cause whose drive is healthy: with a spring brake that failed unnoticed and a hydraulic
  brake that builds no pressure, regeneration is the only brake left, and cutting the drive's
  power would throw it away.

Why an abrupt standstill is held: a wheel sensor that dies inside its plausibility check's blind
spot (`speed_check.blind_spot_mps`, 0.45 m/s by default) drops to 0 as a real stop would, but at
once, from a speed above `STANDSTILL_LIMIT_MPS`. Were that 0 proof, the stop would cut the drive
at once, and with both mechanical brakes failed (one of them latent) the robot would roll on with
nothing to slow it (found by `bywire verify`, H7). So a standstill the readings came to abruptly
(`SpeedCheckState.standstill_abrupt`) ends the stop only once it has been read for
`standstill_hold_s`: the blind spot's speed divided by the regenerative brake's deceleration
(0.45 / 1.5 = 0.3 s by default; a robot file may not make it longer than 0.5 s), in which
regeneration stops a robot that the dead sensor hid. A standstill reached through readings at or
below the limit, as a braking robot's are, ends it at once, as does one read before the stop.

A stop that begins with the drive already off (power-up, a stop after a stop) is category 0:
there is nothing to keep powered. `stop_step` is pure: the controller calls it on every
decision with the latched causes' category, the previous decision's drive and a trusted speed.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from bywire.control.values import slot_init

MIN_CONTROLLED_STOP_S = 2.0
MAX_CONTROLLED_STOP_S = 3.0
"""The requirement's bounds on how long a controlled stop keeps the drive powered without a
speed that says it stands still: long enough for regeneration alone to stop the robot from its
top speed, short enough that a drive left powered is soon off (`[stop] controlled_max_s`)."""
STANDSTILL_LIMIT_MPS = 0.1
"""A controlled stop ends (power off) at a trusted speed no faster than this, whatever the
interlock's own standstill threshold: the rest of the way, rolling drag alone stops the robot
within a centimetre or two."""
GRACE_S = 0.3
"""How long the brakes may take to bite before the deceleration is judged."""
SPEED_MARGIN_MPS = 0.15
"""What a wheel-speed reading may be off by (a reading's step, a bump) when judged."""


class StopCategory(enum.IntEnum):
    """IEC 60204-1's stop categories that bywire uses (category 2 keeps power at standstill)."""

    POWER_OFF = 0
    CONTROLLED = 1


class StopPhase(enum.Enum):
    """What the drive does now."""

    DRIVING = "not stopping"
    BRAKING = "category 1: drive powered, braking with throttle at 0 V"
    POWER_OFF = "drive power removed"


@dataclass(frozen=True, slots=True)
class StopConfig:
    """How long a controlled stop may keep the drive powered, and the least deceleration it
    must show (judged after `GRACE_S`) before it gives up and removes power."""

    controlled_max_s: float = 2.5
    controlled_min_decel_mps2: float = 0.5
    standstill_mps: float = 0.05
    standstill_hold_s: float = 0.3  # the default robot's (`config.deadlines.standstill_hold_s`)


@dataclass(frozen=True, slots=True)
class StopState:
    """The stop under way: when it began with the drive powered, the speed then, and whether
    power is off (done, or given up: `escalated`)."""

    since_s: float | None = None
    start_speed_mps: float | None = None
    power_off: bool = False
    escalated: bool = False

    def __init__(
        self,
        since_s: float | None = None,
        start_speed_mps: float | None = None,
        power_off: bool = False,
        escalated: bool = False,
    ) -> None:
        object.__setattr__(self, "since_s", since_s)
        object.__setattr__(self, "start_speed_mps", start_speed_mps)
        object.__setattr__(self, "power_off", power_off)
        object.__setattr__(self, "escalated", escalated)


slot_init(StopState)


NOT_STOPPING = StopState()


def stop_step(
    state: StopState,
    *,
    stopping: bool,
    category: StopCategory,
    powered: bool,
    speed_mps: float | None,
    now: float,
    config: StopConfig,
    standstill_proven_s: float | None,
) -> tuple[StopState, StopPhase]:
    """The next stop state and what the drive does.

    `stopping`: the mode is STOP; `category`: the latched causes' (`POWER_OFF` if any is);
    `powered`: the previous decision left the drive enabled; `speed_mps`: a speed the controller
    trusts (None without one: then only `controlled_max_s` ends the stop);
    `standstill_proven_s`: from when the standstill the sensor reads is proof
    (`standstill_proven_since`; None: it reads none).
    """
    if not stopping:
        return NOT_STOPPING, StopPhase.DRIVING
    if state.since_s is None:
        state = StopState(since_s=now, start_speed_mps=_magnitude(speed_mps), power_off=not powered)
    if not state.power_off:
        speed = _magnitude(speed_mps)
        stood = standstill_proven_s is not None and now >= standstill_proven_s
        state = _judged(state, category, speed, now, config, stood=stood)
    return state, StopPhase.POWER_OFF if state.power_off else StopPhase.BRAKING


def _judged(
    state: StopState,
    category: StopCategory,
    speed: float | None,
    now: float,
    config: StopConfig,
    *,
    stood: bool,
) -> StopState:
    """A controlled stop under way, judged at `now`: it goes on, or power goes off (`stood`:
    the standstill the sensor reads is proof, `standstill_proven_since`)."""
    since_s = now if state.since_s is None else state.since_s
    if category is StopCategory.POWER_OFF or now - since_s >= config.controlled_max_s:
        return _off(state)
    if speed is None:  # no speed to judge by: the time bound alone
        return state
    if speed <= config.standstill_mps:
        return _off(state) if stood else state
    if speed > _allowed_speed_mps(state, now, config):
        return _off(state, escalated=True)
    return state


def standstill_proven_since(
    since_s: float | None, abrupt: bool, config: StopConfig
) -> float | None:
    """From when a standstill read since `since_s` ends a controlled stop: at once, or after
    `standstill_hold_s` when the readings came to it `abrupt`ly (see the module's text)."""
    if since_s is None:
        return None
    return since_s + config.standstill_hold_s if abrupt else since_s


def _allowed_speed_mps(state: StopState, now: float, config: StopConfig) -> float:
    """The fastest a robot braking at `controlled_min_decel_mps2` since `GRACE_S` after the start
    can be."""
    start = state.start_speed_mps
    if start is None or state.since_s is None:  # no trusted speed at the start: none to judge
        return math.inf
    braking_s = max(now - state.since_s - GRACE_S, 0.0)
    return start + SPEED_MARGIN_MPS - config.controlled_min_decel_mps2 * braking_s


def _off(state: StopState, *, escalated: bool = False) -> StopState:
    return StopState(state.since_s, state.start_speed_mps, True, state.escalated or escalated)


def _magnitude(speed_mps: float | None) -> float | None:
    return None if speed_mps is None or math.isnan(speed_mps) else abs(speed_mps)
