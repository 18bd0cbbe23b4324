"""Control-mode multiplexer: the RC switch chooses CAN, RC or STOP (thesis Figure 14, R-MUX).

Safety rules kept here, as one small state machine: a lost or implausible RC link means STOP, and
so does the selected CAN source going stale: never a fall-back to the other source. STOP entered
by a fault is latched and is left only by moving the mode switch through STOP (or a CAN re-enable
edge once the cause is gone), and only with zero throttle from the source that takes over.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.control.rc_mapping import RcRequest
from bywire.model import ControlMode, Gear, MovementCommand


@dataclass(frozen=True, slots=True)
class Movement:
    """The movement set-point the actuators follow, whichever source it came from."""

    steering_norm: float = 0.0
    throttle_norm: float = 0.0
    brake_norm: float = 1.0
    gear: Gear = Gear.NEUTRAL


STOPPED = Movement()


@dataclass(frozen=True, slots=True)
class MuxInputs:
    """The usable inputs at one instant: None means missing, stale or invalid."""

    rc: RcRequest | None
    can_movement: MovementCommand | None
    remote_stop: bool = False
    re_enable: bool = False
    hardware_fault: bool = False


class Latch(enum.Enum):
    """Why STOP is latched."""

    POWER_UP = "power-up: move the mode switch through STOP to arm"
    RC_LOST = "RC link lost or implausible"
    CAN_LOST = "CAN commands stale while in CAN mode"
    REMOTE_STOP = "remote stop requested over CAN"
    HARDWARE_FAULT = "actuator fault (DAC writes failing, watchdog)"


CAN_CLEARABLE = frozenset({Latch.CAN_LOST, Latch.REMOTE_STOP})


@dataclass(frozen=True, slots=True)
class MuxState:
    """The selected mode and, while STOP is latched, why."""

    mode: ControlMode = ControlMode.STOP
    latch: Latch | None = Latch.POWER_UP
    re_enable_seen: bool = False


def _fault(inputs: MuxInputs) -> Latch | None:
    if inputs.hardware_fault:
        return Latch.HARDWARE_FAULT
    if inputs.rc is None:
        return Latch.RC_LOST
    if inputs.remote_stop:
        return Latch.REMOTE_STOP
    if inputs.rc.mode is ControlMode.CAN and inputs.can_movement is None:
        return Latch.CAN_LOST
    return None


def movement_from(mode: ControlMode, inputs: MuxInputs) -> Movement:
    """The set-point of the selected source; STOP (or a missing source) is a full stop."""
    if mode is ControlMode.RC and inputs.rc is not None:
        rc = inputs.rc
        return Movement(rc.steering_norm, rc.throttle_norm, rc.brake_norm, rc.gear)
    if mode is ControlMode.CAN and inputs.can_movement is not None:
        can = inputs.can_movement
        return Movement(can.steering_norm, can.throttle_norm, can.brake_norm, can.gear)
    return STOPPED


def mux_step(state: MuxState, inputs: MuxInputs) -> MuxState:
    """Next mode. Pure; evaluated on every input and every control cycle."""
    re_enable_edge = inputs.re_enable and not state.re_enable_seen
    fault = _fault(inputs)
    if fault is not None or inputs.rc is None:
        return MuxState(ControlMode.STOP, fault, inputs.re_enable)
    requested = inputs.rc.mode
    if requested is ControlMode.STOP:
        return MuxState(ControlMode.STOP, None, inputs.re_enable)
    latch = None if state.latch in CAN_CLEARABLE and re_enable_edge else state.latch
    if latch is not None:
        return MuxState(ControlMode.STOP, latch, inputs.re_enable)
    leaving_stop = state.mode is ControlMode.STOP
    if leaving_stop and movement_from(requested, inputs).throttle_norm > 0.0:
        return MuxState(ControlMode.STOP, None, inputs.re_enable)
    return MuxState(requested, None, inputs.re_enable)
