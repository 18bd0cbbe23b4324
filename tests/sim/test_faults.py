"""The fault table is the one place a fault is defined: the loader's names and the run's
actions come from it, and every row applies to a running simulated robot."""

from __future__ import annotations

import pytest

from bywire.config import default_sim_config
from bywire.sim.faults import BY_NAME, FAULTS
from bywire.sim.runner import SimRun
from bywire.sim.scenario import FAULTS as SCENARIO_FAULTS
from bywire.sim.scenario import parse_scenario

VIRTUAL = [fault.name for fault in FAULTS if fault.name != "loop_stall"]  # that one is wall time


def test_the_loader_knows_exactly_the_faults_of_the_table() -> None:
    assert list(SCENARIO_FAULTS) == [fault.name for fault in FAULTS]
    assert len(BY_NAME) == len(FAULTS)
    assert all(fault.description for fault in FAULTS)


@pytest.mark.parametrize("name", VIRTUAL)
def test_every_fault_applies_to_a_running_simulated_robot(name: str) -> None:
    text = f'name = "f"\nduration_s = 0.3\n[[event]]\nat_s = 0.1\nfault = "{name}"\n'
    run = SimRun(default_sim_config(), parse_scenario(text, "<test>"))
    applied: list[str] = []
    run.on_event.append(lambda event, _now: applied.append(str(event.values["fault"])))
    run.run()
    assert applied == [name]
