"""The oracle's cause model beside the controller's (issue 42, item 3).

The oracle keeps its own model (`OracleCause`: what was done to the robot), independent of the
controller's latched causes (`control.supervisor.Cause`: what the controller concluded), so
that one mistake is not made twice. This test is the only place the two meet: it says which
oracle causes model each controller cause, and names, with the reason, every controller cause
the oracle does not model. A new controller cause fails here until it is one or the other.
"""

from __future__ import annotations

from collections.abc import Mapping

import pytest

from bywire.control.stop import StopCategory
from bywire.control.supervisor import CAN_BOUND, CAN_CLEARABLE, Cause
from bywire.sim.verify.oracle.causes import CAN_ONLY, POWER_OFF, SWITCH_ONLY, OracleCause

MODELLED: Mapping[Cause, frozenset[OracleCause]] = {
    Cause.RC_LOST: frozenset({OracleCause.RC_LINK_LOST}),
    Cause.RC_IMPLAUSIBLE: frozenset({OracleCause.RC_FAILSAFE, OracleCause.RC_IMPLAUSIBLE}),
    Cause.CAN_LOST: frozenset({OracleCause.CAN_LOST, OracleCause.CAN_UNPLUGGED}),
    Cause.CAN_UNTRUSTED: frozenset({OracleCause.CAN_IMPOSTOR}),
    Cause.REMOTE_STOP: frozenset({OracleCause.REMOTE_STOP}),
    Cause.DAC_FAULT: frozenset({OracleCause.DAC_FAIL}),
    # a DAC transfer slower than any robot file's budget; the oracle models no overrun of a
    # pass or a port write on their own (the simulator has no fault that makes one)
    Cause.TIMING: frozenset({OracleCause.DAC_SLOW}),
    Cause.WATCHDOG: frozenset({OracleCause.WATCHDOG}),
    Cause.ESTOP: frozenset({OracleCause.ESTOP_PRESSED, OracleCause.ESTOP_WIRE}),
}
"""Each controller cause the oracle models, and the oracle causes that demand its stop."""

NOT_MODELLED: Mapping[Cause, str] = {
    # nothing is done to the robot: the oracle's arming tracker starts at STOP and holds the
    # robot there until the first deliberate arming act (H1), which is this cause's rule
    Cause.POWER_UP: "the oracle starts at STOP",
    # a broken brake is a fact of the plant (`Plant.hydrobrake_failed`), judged by H10 (the
    # e-brake within 0.5 s at a duty of 0.2 or more), not a demand for STOP by itself
    Cause.HYDRO_PRESSURE: "judged by H10 from the plant",
    # a stuck servo likewise (`Plant.servo_stuck`, H10); a dead encoder (`encoder_fail`) the
    # oracle does not judge at all: its rule is `nothing`
    Cause.STEERING_ENCODER: "judged by H10 from the plant; a dead encoder not at all",
}
"""Controller causes the oracle does not model as a demand for STOP, and why."""

ORACLE_ONLY: Mapping[OracleCause, str] = {
    # the operator's switch at STOP is the controller's mode, not a latched cause
    OracleCause.SWITCH_STOP: "the controller's STOP mode, no cause",
}
"""Oracle causes that model no controller cause."""


def test_every_controller_cause_is_modelled_or_named_as_not() -> None:
    assert set(MODELLED) | set(NOT_MODELLED) == set(Cause)
    assert set(MODELLED) & set(NOT_MODELLED) == set()


def test_every_oracle_cause_models_a_controller_cause_or_says_why_not() -> None:
    modelling = frozenset().union(*MODELLED.values())
    assert modelling | set(ORACLE_ONLY) == set(OracleCause)
    assert modelling & set(ORACLE_ONLY) == set()


@pytest.mark.parametrize("cause", list(MODELLED), ids=lambda cause: cause.name)
def test_the_two_models_agree_on_the_stop_category(cause: Cause) -> None:
    """Two models written apart: a cause that powers the drive off is one for both."""
    power_off = cause.category is StopCategory.POWER_OFF
    assert {oracle_cause in POWER_OFF for oracle_cause in MODELLED[cause]} == {power_off}


@pytest.mark.parametrize("cause", list(MODELLED), ids=lambda cause: cause.name)
def test_the_two_models_agree_on_what_stops_can_mode_only(cause: Cause) -> None:
    can_bound = cause in CAN_BOUND
    assert {oracle_cause in CAN_ONLY for oracle_cause in MODELLED[cause]} == {can_bound}


def test_what_only_the_switch_clears_for_the_oracle_no_re_enable_clears_in_the_controller() -> None:
    clearable = frozenset().union(*(MODELLED[cause] for cause in CAN_CLEARABLE))
    assert SWITCH_ONLY & clearable == set()
