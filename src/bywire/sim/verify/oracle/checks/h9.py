"""H9 **a handover is bumpless for the steering.** Once a source takes over (the switch settled
on it, or a re-enable), the steering pulse moves towards that source's steering no faster than
`REQUIRED_HANDOVER_RATE` (full ranges per second below 1 m/s, falling as 1/speed above; a range
is each side's own, centre to its end pulse) until it has reached it (not judged with a boosted
steering, whose pulse leads its set-point)."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.model import ControlMode
from bywire.sim.verify.oracle.cause_deadlines import ServoPulses
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import REQUIRED_HANDOVER_RATE

REACHED_NORM = 0.02
"""The pulse within this share of the half span of the source's steering has reached it; a
step may exceed the rate by as much."""


@dataclass(frozen=True, slots=True)
class TakeOver:
    """A source taking over: its steering is judged from `from_s` until the pulse reaches it;
    `last` is the (time, pulse) of the previous pass judged."""

    source: ControlMode
    from_s: float
    last: tuple[float, float] | None = None


def handover_rate(speed_mps: float) -> float:
    """The fastest a handover may move the steering at `speed_mps` (full ranges per second)."""
    speed = abs(speed_mps)
    return REQUIRED_HANDOVER_RATE * min(1.0, 1.0 / speed) if speed > 0.0 else REQUIRED_HANDOVER_RATE


def check_h9(
    taking: TakeOver, out: Outputs, target_norm: float, servo: ServoPulses, now: float
) -> tuple[TakeOver | None, Violation | None]:
    """`target_norm`: the steering of the source taking over. Returns None for the take-over
    once the pulse has reached it."""
    if not out.released or now < taking.from_s:
        # In STOP the steering holds; the move counts once driving.
        return TakeOver(taking.source, taking.from_s), None  # not `replace`: every pass
    pulse_s = out.steering_pulse_s
    if abs(pulse_s - servo.pulse_s(target_norm)) <= REACHED_NORM * servo.half_span_s:
        return None, None
    last, taking = taking.last, TakeOver(taking.source, taking.from_s, (now, pulse_s))
    if last is None or now <= last[0]:
        return taking, None
    speed = abs(out.speed_mps)
    last_norm, now_norm = servo.norm_of(last[1]), servo.norm_of(pulse_s)
    moved_norm = abs(now_norm - last_norm)  # in steering norms: each side on its own span
    allowed_norm = handover_rate(speed) * (now - last[0]) + REACHED_NORM
    if moved_norm <= allowed_norm:
        return taking, None
    edge_s = servo.pulse_s(last_norm + (allowed_norm if now_norm > last_norm else -allowed_norm))
    bound = (
        {"steering_pulse_max_s": edge_s} if pulse_s > last[1] else {"steering_pulse_min_s": edge_s}
    )
    detail = (
        f"taking over from {taking.source.name}: the steering moved {moved_norm:.2f} in"
        f" {now - last[0]:.3f} s at {speed:.2f} m/s (at most {allowed_norm:.2f})"
    )
    return taking, Violation.of(Invariant.H9, now, detail, **bound)
