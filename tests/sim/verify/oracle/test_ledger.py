"""The stop ledger alone: each request's deadline, what sets it, what the switch alone may
clear and from when."""

from __future__ import annotations

import pytest

from bywire.model import ControlMode
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.ledger import Demand
from bywire.sim.verify.oracle.requirements import DAC_LATCH_WRITES
from tests.sim.verify.oracle.parts import TIMING, parts


def test_a_request_while_armed_sets_its_deadline_and_disarms() -> None:
    ledger = parts().ledger
    ledger.arm()
    ledger.request(OracleCause.REMOTE_STOP, 1.0)
    deadline_s = 1.0 + TIMING.deadline_s(OracleCause.REMOTE_STOP)
    assert ledger.demand() == Demand(False, deadline_s, frozenset({OracleCause.REMOTE_STOP}))
    assert ledger.allows(deadline_s - 0.001)
    assert not ledger.allows(deadline_s)


def test_a_later_request_can_only_bring_the_deadline_sooner() -> None:
    ledger = parts().ledger
    ledger.arm()
    ledger.request(OracleCause.CAN_LOST, 1.0)
    ledger.request(OracleCause.REMOTE_STOP, 1.01)
    assert ledger.deadline_s == 1.01 + TIMING.deadline_s(OracleCause.REMOTE_STOP)
    ledger.request(OracleCause.CAN_LOST, 1.02)  # later than the deadline it has
    assert ledger.deadline_s == 1.01 + TIMING.deadline_s(OracleCause.REMOTE_STOP)
    assert ledger.stopped_by == {OracleCause.CAN_LOST, OracleCause.REMOTE_STOP}


def test_a_request_after_the_stop_has_no_deadline_to_move() -> None:
    ledger = parts().ledger  # power-up: not armed, nothing allowed
    ledger.request(OracleCause.REMOTE_STOP, 1.0)
    assert ledger.demand() == Demand(False, None, frozenset())


def test_what_frames_carry_arrives_after_their_corruption_and_not_while_the_link_is_lost() -> None:
    p = parts()
    p.ledger.arm()
    p.delays.blind(ControlMode.RC, 1.0, 1.1)
    p.ledger.request(OracleCause.SWITCH_STOP, 1.05)
    assert p.ledger.deadline_s == 1.1 + TIMING.deadline_s(OracleCause.SWITCH_STOP)
    lost = parts()
    lost.ledger.arm()
    lost.faults.causes.add(OracleCause.RC_LINK_LOST)
    lost.ledger.request(OracleCause.SWITCH_STOP, 1.05)
    assert lost.ledger.armed


def test_failsafe_frames_carry_no_switch_position_but_implausible_ones_still_stop() -> None:
    p = parts()
    p.ledger.arm()
    p.faults.causes.add(OracleCause.RC_FAILSAFE)
    p.ledger.request(OracleCause.SWITCH_STOP, 1.0)
    assert p.ledger.armed
    p.ledger.request(OracleCause.RC_IMPLAUSIBLE, 1.0)
    assert not p.ledger.armed


def test_a_cause_that_makes_the_drive_suspect_demands_power_off_from_its_deadline() -> None:
    ledger = parts().ledger
    ledger.arm()
    ledger.request(OracleCause.REMOTE_STOP, 1.0)
    assert ledger.power_off_from is None
    ledger.request(OracleCause.DAC_SLOW, 1.0)
    due_s = 1.0 + TIMING.deadline_s(OracleCause.DAC_SLOW)
    assert ledger.power_off_from == due_s
    assert not ledger.power_off_demanded(due_s - 0.001)
    assert ledger.power_off_demanded(due_s)
    tripped = parts().ledger
    tripped.tripped(2.0)
    assert tripped.power_off_demanded(2.0)
    assert tripped.owed_now(2.001) == {OracleCause.WATCHDOG}


def test_only_can_bound_causes_leave_a_can_stop_pending() -> None:
    ledger = parts().ledger
    ledger.arm()
    ledger.request(OracleCause.CAN_IMPOSTOR, 1.0)
    assert ledger.can_stop_pending(1.1)
    assert not ledger.can_stop_pending(1.0 + TIMING.deadline_s(OracleCause.CAN_IMPOSTOR))
    ledger.request(OracleCause.DAC_FAIL, 1.01)
    assert not ledger.can_stop_pending(1.02)


def test_a_hang_postpones_a_stop_not_yet_acted_on() -> None:
    p = parts()
    p.ledger.arm()
    p.ledger.request(OracleCause.REMOTE_STOP, 1.0)
    p.delays.hang(1.01, 1.2)
    p.ledger.postpone()
    assert p.ledger.deadline_s == 1.2 + 2 * TIMING.control_period_s


def test_implausible_frames_that_corruption_takes_whole_demand_nothing() -> None:
    p = parts()
    p.ledger.arm()
    p.ledger.implausible(2, 1.0)
    assert not p.ledger.armed
    assert OracleCause.RC_IMPLAUSIBLE in p.ledger.owed
    p.ledger.rc_blind(1.005, 1.1)  # before the first frame went out, past the last
    assert p.ledger.armed
    assert OracleCause.RC_IMPLAUSIBLE not in p.ledger.owed


def test_implausible_frames_sent_before_the_corruption_still_demand_the_stop() -> None:
    p = parts()
    p.ledger.arm()
    p.ledger.implausible(2, 1.0)
    p.ledger.rc_blind(1.0 + TIMING.frame_s + 0.001, 1.1)
    assert not p.ledger.armed


def test_failing_dac_writes_latch_for_sure_after_their_writes_reach_the_dac() -> None:
    p = parts()
    p.faults.began[OracleCause.DAC_FAIL] = (1.0, True)
    p.faults.dac_writes_from = 1.5  # a trip held the gate until then
    latch_s = DAC_LATCH_WRITES * TIMING.driving_period_s
    assert p.ledger.latched_from(OracleCause.DAC_FAIL) == pytest.approx(1.5 + latch_s)
    p.ledger.ended(OracleCause.DAC_FAIL, 1.5 + latch_s + 0.01)
    assert p.ledger.owed_now(2.0) == {OracleCause.DAC_FAIL}
    assert p.ledger.latched_from(OracleCause.REMOTE_STOP) is None  # CAN's to clear


def test_failsafe_frames_latch_only_while_frames_arrive() -> None:
    p = parts()
    p.faults.began[OracleCause.RC_FAILSAFE] = (1.0, True)
    assert p.ledger.latched_from(OracleCause.RC_FAILSAFE) == 1.0 + TIMING.deadline_s(
        OracleCause.RC_FAILSAFE
    )
    p.faults.causes.add(OracleCause.RC_LINK_LOST)
    assert p.ledger.latched_from(OracleCause.RC_FAILSAFE) is None


def test_a_second_sender_latches_only_when_it_met_the_robot_driving_in_can_alone() -> None:
    p = parts()
    p.faults.began[OracleCause.CAN_IMPOSTOR] = (1.0, True)
    p.ledger.stopped_by = {OracleCause.CAN_IMPOSTOR}
    assert p.ledger.latched_from(OracleCause.CAN_IMPOSTOR) is None  # the motors were off
    p.faults.impostor_met_drive = True
    assert p.ledger.latched_from(OracleCause.CAN_IMPOSTOR) == 1.0 + TIMING.deadline_s(
        OracleCause.CAN_IMPOSTOR
    )
    p.ledger.stopped_by = {OracleCause.CAN_IMPOSTOR, OracleCause.REMOTE_STOP}  # another stop first
    assert p.ledger.latched_from(OracleCause.CAN_IMPOSTOR) is None


def test_a_power_off_cause_that_passed_unseen_withdraws_only_its_own_demand() -> None:
    ledger = parts().ledger
    ledger.request(OracleCause.DAC_FAIL, 1.0)
    ledger.request(OracleCause.WATCHDOG, 1.01)
    dac_s = 1.0 + TIMING.deadline_s(OracleCause.DAC_FAIL)
    assert ledger.power_off_from == min(dac_s, 1.01 + TIMING.deadline_s(OracleCause.WATCHDOG))
    ledger.passed_unseen(OracleCause.DAC_FAIL)
    assert ledger.power_off_from == 1.01 + TIMING.deadline_s(
        OracleCause.WATCHDOG
    )  # the other's stays
    ledger.passed_unseen(OracleCause.WATCHDOG)
    assert ledger.power_off_from is None
    assert not ledger.power_off_demanded(5.0)
    ledger.request(OracleCause.DAC_FAIL, 6.0)  # not withdrawn: demanded once its deadline passes
    assert ledger.power_off_demanded(6.0 + TIMING.deadline_s(OracleCause.DAC_FAIL))
