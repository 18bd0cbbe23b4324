"""The condition table is the one place an expectation's condition is defined."""

from __future__ import annotations

from bywire.config import default_sim_config
from bywire.sim.conditions import CONDITIONS, conditions_hold
from bywire.sim.runner import SimRun
from bywire.sim.scenario import CONDITIONS as LOADER_CONDITIONS
from bywire.sim.scenario import parse_scenario


def test_the_loader_takes_its_keys_and_descriptions_from_the_table() -> None:
    assert {c.key: c.description for c in CONDITIONS} == LOADER_CONDITIONS


def test_every_condition_refuses_a_value_of_no_kind_it_takes() -> None:
    for condition in CONDITIONS:
        assert condition.check({"a": "table"}) is not None, condition.key


def test_conditions_are_judged_on_what_the_robot_shows() -> None:
    run = SimRun(default_sim_config(), parse_scenario('name = "c"\nduration_s = 0.2\n', "<t>"))
    record = run.run()
    at_rest = record.samples[-1]  # the switch held at STOP since power-up: nothing latched
    assert conditions_hold(at_rest, {"mode": "STOP", "latched": False, "ebrake_engaged": True})
    assert conditions_hold(at_rest, {"throttle_volts_max": 0.0, "speed_max_mps": 0.0})
    assert not conditions_hold(at_rest, {"mode": "rc"})
    assert not conditions_hold(at_rest, {"latched": True})
    assert not conditions_hold(at_rest, {"motors_enabled": True})
    assert not conditions_hold(at_rest, {"throttle_volts_min": 0.5})
