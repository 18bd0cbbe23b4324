"""Each fault's oracle rule (`fault_rules.RULES`, one per row of `faults.FAULTS`): what the
oracle is told when the fault is injected, through the campaign's witness, on a robot armed and
driving in CAN at 1 s. Every row's rule is decided here: a new fault fails
`test_every_fault_has_a_decided_rule` until it has one."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode
from bywire.sim.faults import BY_NAME
from bywire.sim.scenario import Event
from bywire.sim.verify.fault_rules import IMPOSTOR_PERIOD_S, nothing
from bywire.sim.verify.fault_rules import RULES as FAULT_RULES
from bywire.sim.verify.oracle import HazardOracle, OracleCause, OracleTiming
from bywire.sim.verify.witness import OracleWitness

AT_S = 1.0
TIMING = OracleTiming()
FRAME_S = TIMING.frame_s


def _witness(authenticated: bool = False, switch: ControlMode = ControlMode.CAN) -> OracleWitness:
    robot = default_sim_config()
    clock = VirtualClock()
    oracle = HazardOracle(SimWorld.from_robot(clock, robot), timing=TIMING)
    oracle.set_switch(switch, 0.2)
    oracle.arming.resolve(0.5)
    assert oracle.ledger.armed
    return OracleWitness(oracle, clock, authenticated)


def _inject(witness: OracleWitness, name: str, **values: Any) -> HazardOracle:
    witness(Event(AT_S, "fault", {"fault": name, "count": 1, **values}), AT_S)
    return witness.oracle


def _in_force(cause: OracleCause) -> Callable[[HazardOracle], bool]:
    return lambda oracle: cause in oracle.faults and not oracle.ledger.armed


def _rc_blind_for_4_frames(oracle: HazardOracle) -> bool:
    return oracle.delays.rc_blind_until == AT_S + 4 * FRAME_S


def _can_blind_for_2_frames(oracle: HazardOracle) -> bool:
    return oracle.delays.can_blind_until == AT_S + 2 * IMPOSTOR_PERIOD_S


RULES: dict[str, tuple[dict[str, Any], Callable[[HazardOracle], bool]] | None] = {
    "rc_link_lost": ({}, _in_force(OracleCause.RC_LINK_LOST)),
    "rc_failsafe": ({}, _in_force(OracleCause.RC_FAILSAFE)),
    "ibus_garbage": ({"count": 64}, _rc_blind_for_4_frames),  # two IBUS frames' worth, and two more
    "ibus_corrupt": ({"count": 3}, _rc_blind_for_4_frames),  # three, and the one in flight
    "can_silence": ({}, _in_force(OracleCause.CAN_LOST)),
    "can_unplug": ({}, _in_force(OracleCause.CAN_UNPLUGGED)),
    "can_corrupt_crc": ({}, _can_blind_for_2_frames),
    "can_corrupt_length": ({}, _can_blind_for_2_frames),
    "can_corrupt_counter": ({}, _can_blind_for_2_frames),
    "can_corrupt_range": ({}, _can_blind_for_2_frames),
    "dac_fail": ({}, lambda o: _in_force(OracleCause.DAC_FAIL)(o) and not o.faults.dac_every_other),
    "dac_nak_alternate": (
        {},
        lambda o: _in_force(OracleCause.DAC_FAIL)(o) and o.faults.dac_every_other,
    ),
    "hydrobrake_fail": ({}, lambda o: o.plant.hydrobrake_failed and o.ledger.armed),
    "ebrake_fail": ({}, lambda o: o.plant.ebrake_failed and o.ledger.armed),
    "dac_stall": (
        {"stall_s": 0.3},
        lambda o: o.ledger.tripped_at is not None and o.faults.dac_writes_from == float("inf"),
    ),
    "switch_chatter": ({"count": 10}, lambda o: OracleCause.SWITCH_STOP in o.ledger.stopped_by),
    "rc_implausible": ({"count": 2}, lambda o: OracleCause.RC_IMPLAUSIBLE in o.ledger.stopped_by),
    "can_impostor": ({"count": 5}, _in_force(OracleCause.CAN_IMPOSTOR)),
    "can_forgery": ({"count": 5}, _in_force(OracleCause.CAN_IMPOSTOR)),
    "can_skip_forgery": ({"count": 5}, _in_force(OracleCause.CAN_IMPOSTOR)),
    "dac_slow": ({"stall_s": 0.08}, _in_force(OracleCause.DAC_SLOW)),
    "line_dead": ({"line": "brake_light"}, lambda o: o.plant.dead_lines == {"brake_light"}),
    "wheel_sensor_dead": ({}, lambda o: o.plant.sensor_dead and o.ledger.armed),
    "estop_press": ({}, _in_force(OracleCause.ESTOP_PRESSED)),
    "estop_wire_break": ({}, _in_force(OracleCause.ESTOP_WIRE)),
    "estop_chatter": ({"count": 7}, _in_force(OracleCause.ESTOP_PRESSED)),
    # Endings, each after its beginning a second before (`test_an_ending_ends_its_beginning`).
    "rc_link_restored": None,
    "rc_failsafe_off": None,
    "can_resume": None,
    "can_plug": None,
    "dac_restore": None,
    "hydrobrake_restore": None,
    "wheel_sensor_restore": None,
    "estop_release": None,
    "estop_wire_mend": None,
    # Nothing the oracle must know: `nothing`.
    "can_flood": None,
    "can_flood_off": None,
    "servo_stuck": ({}, lambda o: o.plant.servo_stuck),  # H10 times it (row 63)
    "servo_free": None,
    "encoder_fail": None,
    "loop_stall": None,
    "switch_dither": None,
    "can_impostor_control": None,
    "can_doubles": None,
    "can_impostor_lights": None,
}
ENDINGS = {
    "rc_link_restored": ("rc_link_lost", OracleCause.RC_LINK_LOST),
    "rc_failsafe_off": ("rc_failsafe", OracleCause.RC_FAILSAFE),
    "can_resume": ("can_silence", OracleCause.CAN_LOST),
    "can_plug": ("can_unplug", OracleCause.CAN_UNPLUGGED),
    "dac_restore": ("dac_fail", OracleCause.DAC_FAIL),
    "estop_release": ("estop_press", OracleCause.ESTOP_PRESSED),
    "estop_wire_mend": ("estop_wire_break", OracleCause.ESTOP_WIRE),
}
MENDED = {
    "hydrobrake_restore": "hydrobrake_fail",
    "wheel_sensor_restore": "wheel_sensor_dead",
    "servo_free": "servo_stuck",
}
NOTHING = [name for name, rule in RULES.items() if rule is None and name not in {*ENDINGS, *MENDED}]


def test_every_fault_has_a_decided_rule() -> None:
    assert set(RULES) == set(BY_NAME)


def test_verify_has_a_rule_for_exactly_the_faults_of_the_scenario_language() -> None:
    """The scenario language does not know of the oracle: this keeps its table and verify's
    rules in step (a fault without a rule would stop a campaign with a KeyError)."""
    assert list(FAULT_RULES) == list(BY_NAME)


@pytest.mark.parametrize("name", [name for name, rule in RULES.items() if rule is not None])
def test_a_fault_tells_the_oracle_what_it_must_expect(name: str) -> None:
    rule = RULES[name]
    assert rule is not None
    values, holds = rule
    assert holds(_inject(_witness(), name, **values))


@pytest.mark.parametrize("name", NOTHING)
def test_a_fault_the_oracle_need_not_know_of_changes_nothing(name: str) -> None:
    assert FAULT_RULES[name] is nothing
    witness = _witness()
    oracle = witness.oracle
    before = repr((oracle.arming, oracle.plant))  # the arming holds the ledger, faults, delays
    _inject(witness, name, load=0.5, stall_s=0.1, line="brake_light")
    assert repr((oracle.arming, oracle.plant)) == before


@pytest.mark.parametrize("name", list(ENDINGS))
def test_an_ending_ends_its_beginning(name: str) -> None:
    begin, cause = ENDINGS[name]
    witness = _witness()
    _inject(witness, begin)
    witness(Event(AT_S + 1.0, "fault", {"fault": name, "count": 1}), AT_S + 1.0)
    assert cause not in witness.oracle.faults
    assert not witness.oracle.ledger.armed  # its stop stands until an arming


@pytest.mark.parametrize("name", list(MENDED))
def test_a_mending_undoes_its_breaking(name: str) -> None:
    witness = _witness()
    before = repr(witness.oracle.plant)
    _inject(witness, MENDED[name])
    assert repr(witness.oracle.plant) != before
    _inject(witness, name)
    assert repr(witness.oracle.plant).replace("ever_dead=True", "ever_dead=False") == before


def test_a_can_bound_fault_away_from_can_refuses_can_and_lets_rc_drive() -> None:
    oracle = _inject(_witness(switch=ControlMode.RC), "can_silence")
    assert OracleCause.CAN_LOST in oracle.faults
    assert oracle.ledger.armed


def test_a_second_sender_without_the_key_is_harmless_with_authentication() -> None:
    assert _inject(_witness(authenticated=True), "can_impostor", count=5).ledger.armed
    keyed = _inject(_witness(authenticated=True), "can_impostor", count=5, keyed=True)
    assert OracleCause.CAN_IMPOSTOR in keyed.faults


def test_a_second_sender_is_over_when_its_last_frame_is_sent() -> None:
    witness = _witness()
    _inject(witness, "can_impostor", count=5)
    witness.clock.advance(AT_S + 5 * IMPOSTOR_PERIOD_S - witness.clock.now() - 0.001)
    assert OracleCause.CAN_IMPOSTOR in witness.oracle.faults
    witness.clock.advance(0.002)
    assert OracleCause.CAN_IMPOSTOR not in witness.oracle.faults


def test_ordinary_and_short_stalls_and_crawls_only_delay_the_loop() -> None:
    crawl = _inject(_witness(), "dac_slow", stall_s=0.002)
    assert crawl.ledger.armed
    # Within the transfer budget: no stop may come later than promised (issue 41).
    assert crawl.delays.write_lag_s == 0.0
    past_budget = _inject(_witness(), "dac_slow", stall_s=0.0036)
    assert past_budget.ledger.armed  # past the file's budget, not past every file's
    assert past_budget.delays.write_lag_s == 2 * 0.0036
    hang = _inject(_witness(), "dac_stall", stall_s=0.05)
    assert hang.ledger.tripped_at is None
    assert hang.delays.hung_until == AT_S + TIMING.control_period_s + 0.05


@pytest.mark.parametrize("name", ["estop_press", "estop_wire_break", "estop_chatter"])
def test_an_estop_fault_on_a_robot_without_an_estop_demands_nothing(name: str) -> None:
    """albert says `[estop] line = "none"`: its controller reads no button, and a press of the
    simulated one is no input; a demand for STOP there would be the oracle's mistake."""
    robot = parse_config('[estop]\nline = "none"\n')
    clock = VirtualClock()
    oracle = HazardOracle(SimWorld.from_robot(clock, robot), timing=TIMING)
    witness = OracleWitness(oracle, clock, False)
    witness(Event(AT_S, "fault", {"fault": name, "count": 7}), AT_S)
    assert OracleCause.ESTOP_PRESSED not in oracle.faults
    assert OracleCause.ESTOP_WIRE not in oracle.faults
    assert not oracle.ledger.stopped_by
