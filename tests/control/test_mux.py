"""Source selection: the set-point of the chosen source, and a full stop otherwise."""

from __future__ import annotations

import pytest

from bywire.control.mux import STOPPED, movement_from
from bywire.control.rc_mapping import RcRequest
from bywire.model import ControlMode, Gear, MovementCommand

RC = RcRequest(ControlMode.RC, 0.1, 0.5, 0.0, Gear.FORWARD, low_beam=False, hazard=False)
CAN = MovementCommand(0.2, 0.3, 0.0, Gear.REVERSE, counter=1)


def test_movement_follows_the_selected_source() -> None:
    assert movement_from(ControlMode.RC, RC, CAN).throttle_norm == 0.5
    assert movement_from(ControlMode.CAN, RC, CAN).steering_norm == pytest.approx(0.2)
    assert movement_from(ControlMode.CAN, RC, CAN).gear is Gear.REVERSE
    assert movement_from(ControlMode.STOP, RC, CAN) == STOPPED


def test_a_missing_source_is_a_full_stop_never_the_other_source() -> None:
    assert movement_from(ControlMode.CAN, RC, None) == STOPPED
    assert movement_from(ControlMode.RC, None, CAN) == STOPPED
    assert (STOPPED.throttle_norm, STOPPED.brake_norm, STOPPED.gear) == (0.0, 1.0, Gear.NEUTRAL)
