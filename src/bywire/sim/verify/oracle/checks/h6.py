"""H6 **brake beats throttle.** With the motors enabled, throttle volts above zero never come
with a brake (regenerative volts or hydraulic duty above zero) for longer than a control period:
the brake and the drive may be written by tasks of their own, one a pass ahead of the other.
Not judged while the DAC may hold an old voltage (the enable line stops the motors then)."""

from __future__ import annotations

from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs

SLACK_S = 0.001


def check_h6(
    since: float | None, out: Outputs, dac_unsure: bool, control_period_s: float, now: float
) -> tuple[float | None, Violation | None]:
    """`since`: from when brake and throttle have shown together (None: they do not)."""
    if not out.enable or out.throttle_volts <= 0.0:  # most passes: nothing to read
        return None, None
    regen, duty = out.regen_volts, out.hydrobrake_duty
    if (regen <= 0.0 and duty <= 0.0) or dac_unsure:
        return None, None
    since = now if since is None else since
    if now - since <= control_period_s + SLACK_S:
        return since, None
    detail = (
        f"throttle {out.throttle_volts:.2f} V with regen {regen:.2f} V, hydraulic duty {duty:.2f}"
    )
    return since, Violation.of(Invariant.H6, now, detail)
