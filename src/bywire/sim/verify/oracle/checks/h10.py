"""H10 **a broken brake or servo is acted on** (R-MONITORS, docs/SAFETY.md rows 5, 7, 50, 62).
On a robot with the monitors' sensors fitted (a pressure sensor, a steering encoder):

- a hydraulic brake that builds no pressure while its duty is `PRESSURE_DUTY` or more engages the
  e-brake within `PRESSURE_DEADLINE_S` of the first pass that shows that duty;
- a servo stuck more than `SERVO_DEVIATION_NORM` off the position its pulse asks for engages the
  e-brake within `SERVO_DEADLINE_S` of the first pass that shows that deviation with the pulse
  held there (a pulse that moves on, by more than `HELD_NORM`, starts the time afresh: the
  deadline is derived for a command the servo does not follow, and no monitor can tell a stuck
  servo from the slowest acceptable one chasing a command that keeps jumping).

Judged on the hardware (the hydraulic duty, the steering pulse, where the servo really is, the
e-brake line) with the requirement's figures, never the file's `[monitors]` keys. A condition
that lapses (the brake let go, the servo back within the deviation, the e-brake engaged by any
cause) starts afresh. With a boosted steering the pulse overshoots the set-point the monitor
compares with by up to the boost's gain: the deviation is judged on the pulse's divided by
1 + gain, the least the set-point's can be (leaning to allowing)."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import (
    PRESSURE_DEADLINE_S,
    PRESSURE_DUTY,
    SERVO_DEADLINE_S,
    SERVO_DEVIATION_NORM,
)

HELD_NORM = 0.01  # a pulse that moves less than this holds its command
DUTY_SLACK = 0.005  # a duty read from the PWM's pulse, not the duty the controller commanded
SLACK_S = 0.005


@dataclass(frozen=True, slots=True)
class BrokenFacts:
    """What the judge knows for H10 at one instant."""

    sensors_fitted: bool  # the pressure sensor and the steering encoder
    hydrobrake_failed: bool
    servo_stuck: bool
    boost_gain: float
    control_period_s: float


@dataclass(frozen=True, slots=True)
class Unnoticed:
    """H10's memory: since when each broken actuator has shown its fault unacted on."""

    pressure_since: float | None = None
    servo_since: float | None = None
    servo_asked_norm: float = 0.0  # where the pulse asked the servo to be at `servo_since`


NOTHING_UNNOTICED = Unnoticed()
"""Nothing broken shows: most passes' memory, one shared value."""


def _since(since: float | None, condition: bool, now: float) -> float | None:
    return (now if since is None else since) if condition else None


def check_h10(
    memory: Unnoticed, out: Outputs, facts: BrokenFacts, now: float
) -> tuple[Unnoticed, Violation | None]:
    if not (facts.sensors_fitted and out.released):
        return NOTHING_UNNOTICED, None
    braking = facts.hydrobrake_failed and out.hydrobrake_duty >= PRESSURE_DUTY + DUTY_SLACK
    deviation = abs(out.asked_steering_norm - out.steering_norm) / (1.0 + facts.boost_gain)
    off = facts.servo_stuck and deviation > SERVO_DEVIATION_NORM
    asked = out.asked_steering_norm
    servo_since = memory.servo_since
    if servo_since is not None and abs(asked - memory.servo_asked_norm) > HELD_NORM:
        servo_since = None  # the pulse moved on: a new command, timed afresh
    servo_since = _since(servo_since, off, now)
    held = memory.servo_asked_norm if servo_since == memory.servo_since else asked
    pressure_since = _since(memory.pressure_since, braking, now)
    if not (  # a new memory only for a change: most passes keep every field as it was
        pressure_since is memory.pressure_since
        and servo_since is memory.servo_since
        and held is memory.servo_asked_norm
    ):
        memory = Unnoticed(pressure_since, servo_since, held)
    slack_s = 2 * facts.control_period_s + SLACK_S
    late = None
    if memory.pressure_since is not None and (
        now - memory.pressure_since > PRESSURE_DEADLINE_S + slack_s
    ):
        late = (
            f"the hydraulic brake builds no pressure at duty {out.hydrobrake_duty:.2f} since"
            f" {memory.pressure_since:.3f} s, the e-brake still released"
            f" (within {PRESSURE_DEADLINE_S} s)"
        )
    elif memory.servo_since is not None and now - memory.servo_since > SERVO_DEADLINE_S + slack_s:
        late = (
            f"the servo stuck at {out.steering_norm:.2f}, its pulse asking"
            f" {out.asked_steering_norm:.2f}, since {memory.servo_since:.3f} s, the e-brake"
            f" still released (within {SERVO_DEADLINE_S} s)"
        )
    if late is None:
        return memory, None
    # Once a fault, not at every pass after: judged afresh from here.
    return NOTHING_UNNOTICED, Violation.of(Invariant.H10, now, late)
