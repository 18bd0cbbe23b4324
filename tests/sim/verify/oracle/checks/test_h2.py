"""H2's check alone: throttle from a source never seen at zero since the switch moved to it,
once the switch has settled."""

from __future__ import annotations

from bywire.model import ControlMode
from bywire.sim.verify.oracle.checks.h2 import HandoverFacts, check_h2
from bywire.sim.verify.oracle.invariants import Invariant

UNSEEN = HandoverFacts(ControlMode.CAN, settled_s=1.0, seen_zero=False)


def test_throttle_from_a_source_never_seen_at_zero_is_flagged_once_settled() -> None:
    assert check_h2(UNSEEN, 1.0, 0.999) is None
    found = check_h2(UNSEEN, 1.0, 1.0)
    assert found is not None
    assert found.invariant is Invariant.H2
    assert found.detail == "CAN never at zero throttle; throttle=1.00 V"
    assert found.expected == {"throttle_volts_max": 0.0}


def test_a_source_seen_at_zero_at_stop_or_without_throttle_is_left_alone() -> None:
    seen = HandoverFacts(ControlMode.CAN, settled_s=1.0, seen_zero=True)
    at_stop = HandoverFacts(ControlMode.STOP, settled_s=1.0, seen_zero=False)
    assert check_h2(seen, 1.0, 2.0) is None
    assert check_h2(at_stop, 1.0, 2.0) is None
    assert check_h2(UNSEEN, 0.0, 2.0) is None
