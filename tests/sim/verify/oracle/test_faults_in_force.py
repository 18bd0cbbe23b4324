"""The faults in force: which refuse an arming, how long each takes to notice, and when the DAC
may hold an old voltage."""

from __future__ import annotations

from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.faults_in_force import FaultsInForce
from tests.sim.verify.oracle.parts import TIMING


def test_a_fault_refuses_an_arming_once_in_force_a_while_and_can_bound_ones_only_into_can() -> None:
    faults = FaultsInForce(TIMING)
    assert not faults.blocking(True, 5.0)
    faults.note(OracleCause.CAN_LOST, 1.0)
    assert OracleCause.CAN_LOST in faults
    assert not faults.blocking(False, 1.29)
    assert faults.blocking(False, 1.31)
    assert not faults.blocking(True, 5.0)


def test_every_other_write_failing_takes_longer_to_notice() -> None:
    faults = FaultsInForce(TIMING)
    assert faults.unnoticed_s(OracleCause.DAC_FAIL) == 3 * TIMING.driving_period_s
    faults.dac_every_other = True
    assert faults.unnoticed_s(OracleCause.DAC_FAIL) == 5 * TIMING.driving_period_s
    assert faults.unnoticed_s(OracleCause.SWITCH_STOP) == 0.0


def test_a_dac_may_hold_an_old_voltage_while_failing_and_a_rewrite_after() -> None:
    faults = FaultsInForce(TIMING)
    assert not faults.dac_unsure(1.0)
    faults.causes.add(OracleCause.DAC_FAIL)
    assert faults.dac_unsure(1.0)
    faults.causes.discard(OracleCause.DAC_FAIL)
    faults.dac_back_at = 1.0
    assert faults.dac_unsure(1.0 + 2 * TIMING.control_period_s)
    assert not faults.dac_unsure(1.0 + 2 * TIMING.control_period_s + 0.001)
