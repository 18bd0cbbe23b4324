"""H8 **the exit path never gives up.** When the controller ends on a failed output (a dead
line), every other output is left at its safe level: enable low, e-brake engaged, hydraulic
brake at full duty, throttle at 0 V (unless the DAC's writes fail: it may hold an old voltage)."""

from __future__ import annotations

from collections.abc import Set

from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import FULL_DUTY


def check_h8(out: Outputs, dead_lines: Set[str], dac_unsure: bool, now: float) -> Violation | None:
    """`dead_lines`: the outputs whose writes fail (by the world's names), not judged."""
    safe = {
        "motors_enable": not out.enable,
        "ebrake_release": not out.released,
        "hydrobrake": out.hydrobrake_duty >= FULL_DUTY,
        "dac": out.throttle_volts <= 0.0 or dac_unsure,
    }
    unsafe = [name for name, ok in safe.items() if not ok and name not in dead_lines]
    if not unsafe:
        return None
    detail = f"after the controller ended: not safe: {', '.join(unsafe)}"
    return Violation.of(Invariant.H8, now, detail)
