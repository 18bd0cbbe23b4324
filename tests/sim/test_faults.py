"""The fault table is the one place a fault is defined: the loader's names and the run's
actions come from it, and every row applies to a running simulated robot."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from bywire.config import default_sim_config
from bywire.sim.faults import BY_NAME, FAULTS
from bywire.sim.runner import SimRun
from bywire.sim.scenario import FAULTS as SCENARIO_FAULTS
from bywire.sim.scenario import parse_scenario

SOURCE = Path(__file__).resolve().parents[2] / "src" / "bywire"

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


SCENARIO_LANGUAGE = sorted((SOURCE / "sim").glob("*.py"))
"""The scenario room: every module of `bywire.sim` beside `verify/`."""


@pytest.mark.parametrize("path", SCENARIO_LANGUAGE, ids=[path.stem for path in SCENARIO_LANGUAGE])
def test_the_scenario_language_never_names_the_verifier(path: Path) -> None:
    """Issue 42: the scenario language stands alone; `bywire verify` builds on it, never the
    other way (imports under `TYPE_CHECKING` or inside functions count too)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module, *(f"{node.module}.{alias.name}" for alias in node.names)]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        assert not [name for name in names if name.startswith("bywire.sim.verify")], (
            f"{path.name}:{node.lineno} imports the verifier"
        )


def test_a_scenario_runs_without_loading_the_verifier() -> None:
    """Loading and running a scenario, with a fault, loads nothing of `bywire.sim.verify`."""
    scenario = 'name = "f"\nduration_s = 0.2\n[[event]]\nat_s = 0.1\nfault = "dac_fail"\n'
    program = (
        "import sys\n"
        "from bywire.config import default_sim_config\n"
        "from bywire.sim.runner import SimRun\n"
        "from bywire.sim.scenario import parse_scenario\n"
        "SimRun(default_sim_config(), parse_scenario(sys.argv[1], '<test>')).run()\n"
        "print(sorted(m for m in sys.modules if m.startswith('bywire.sim.verify')))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", program, scenario],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    assert done.stdout.strip() == "[]"
