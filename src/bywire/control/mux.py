"""Source selection: the movement set-point of the mode the supervisor chose (thesis Figure 14).

Which source commands is `bywire.control.supervisor`'s decision; this module only reads that
source's set-point. STOP, or a source that is missing, stale or invalid, is a full stop: never a
fall-back to the other source.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.rc_mapping import RcRequest
from bywire.control.values import slot_init
from bywire.model import ControlMode, Gear, MovementCommand


@dataclass(frozen=True, slots=True)
class Movement:
    """The movement set-point the actuators follow, whichever source it came from."""

    steering_norm: float = 0.0
    throttle_norm: float = 0.0
    brake_norm: float = 1.0
    gear: Gear = Gear.NEUTRAL

    def __init__(
        self,
        steering_norm: float = 0.0,
        throttle_norm: float = 0.0,
        brake_norm: float = 1.0,
        gear: Gear = Gear.NEUTRAL,
    ) -> None:
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "throttle_norm", throttle_norm)
        object.__setattr__(self, "brake_norm", brake_norm)
        object.__setattr__(self, "gear", gear)


slot_init(Movement)


STOPPED = Movement()


def movement_from(
    mode: ControlMode, rc: RcRequest | None, can_movement: MovementCommand | None
) -> Movement:
    """The set-point of the selected source; STOP (or a missing source) is a full stop."""
    if mode is ControlMode.RC and rc is not None:
        return Movement(rc.steering_norm, rc.throttle_norm, rc.brake_norm, rc.gear)
    if mode is ControlMode.CAN and can_movement is not None:
        can = can_movement
        return Movement(can.steering_norm, can.throttle_norm, can.brake_norm, can.gear)
    return STOPPED
