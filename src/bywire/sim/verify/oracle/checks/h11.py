"""H11 **the speed limit holds** (issue 44, docs/SAFETY.md row 67). On a robot with a speed limit
(`[limits] max_speed_mps`) and a wheel sensor that tells the truth, the vehicle's true speed, in
either direction, never exceeds the limit by more than `requirements.over_limit_margin_mps` (a
fifth of it, at least 0.2 m/s), whoever commands and in every mode.

Judged on the vehicle's true speed, never on what the controller believes. Not judged once the
wheel sensor died in the campaign (a speed the controller cannot see, it can only bound by a
throttle ceiling, which holds on the flat but not downhill: row 67), nor on a robot that fits no
sensor, nor once both mechanical brakes have failed (the spring brake and the hydraulic brake: a
double fault, as for H4; downhill nothing then holds a robot the drive does not brake, in STOP
least of all). One violation per excursion: the speed must come back within the bound before
another."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.values import slot_init
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import over_limit_margin_mps


@dataclass(frozen=True, slots=True)
class LimitFacts:
    """What the judge knows for H11: the file's limit (None: none) and the wheel sensor."""

    limit_mps: float | None
    sensor_trusted: bool  # fitted, and never dead in this campaign
    brakes_failed: bool = False  # the spring brake and the hydraulic brake both

    def __init__(
        self, limit_mps: float | None, sensor_trusted: bool, brakes_failed: bool = False
    ) -> None:
        object.__setattr__(self, "limit_mps", limit_mps)
        object.__setattr__(self, "sensor_trusted", sensor_trusted)
        object.__setattr__(self, "brakes_failed", brakes_failed)


slot_init(LimitFacts)


def check_h11(
    over: bool, out: Outputs, facts: LimitFacts, now: float
) -> tuple[bool, Violation | None]:
    """(`over`: the speed is past the bound now, as the previous pass left it.)"""
    if facts.limit_mps is None or not facts.sensor_trusted or facts.brakes_failed:
        return False, None
    bound_mps = facts.limit_mps + over_limit_margin_mps(facts.limit_mps)
    speed = abs(out.speed_mps)
    if speed <= bound_mps:
        return False, None
    if over:
        return True, None
    detail = (
        f"true speed {speed:.2f} m/s past the limit {facts.limit_mps:g} m/s by more than its"
        f" margin (at most {bound_mps:.2f} m/s), the wheel sensor healthy"
    )
    return True, Violation.of(Invariant.H11, now, detail, speed_max_mps=round(bound_mps, 3))
