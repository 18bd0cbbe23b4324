"""A steering pulse that must stay where it was when a hold began (H3 after a trip, H5 in STOP)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class SteeringHold:
    """The pulse held since `from_s` (None: no hold yet; the next reading begins it)."""

    pulse_s: float | None = None
    from_s: float = 0.0

    def step(self, pulse_s: float, now: float) -> tuple[SteeringHold, bool]:
        """The hold after reading `pulse_s` at `now`, and whether the pulse left it."""
        held = self if self.pulse_s is not None else SteeringHold(pulse_s, now)
        return held, pulse_s != held.pulse_s


NO_HOLD = SteeringHold()
"""Nothing held: most passes' memory, one shared value."""
