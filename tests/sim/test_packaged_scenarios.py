"""Every packaged fault-injection scenario passes its own expectations on the default robot."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from bywire.config import default_sim_config
from bywire.config.speed_limit import LimitsSection
from bywire.sim.runner import SimRun
from bywire.sim.scenario import load_scenario, parse_scenario

SCENARIOS = sorted((Path(__file__).resolve().parents[2] / "src/bywire/scenarios").glob("*.toml"))
# tests/system runs the test course; real-time scenarios are measurements on a noisy shared
# machine, like the benchmark: tests/system/test_watchdog.py checks the behaviour of loop-stall.
REALTIME = {path.stem for path in SCENARIOS if load_scenario(path).realtime}
# Scenarios without expectations set the stage for a person (bywire teleop), they check nothing.
INTERACTIVE = {path.stem for path in SCENARIOS if not load_scenario(path).expectations}
FAULTS = [
    path
    for path in SCENARIOS
    if path.stem != "test-course" and path.stem not in REALTIME | INTERACTIVE
]


def test_the_folder_holds_the_fault_scenarios() -> None:
    names = {path.stem for path in SCENARIOS}
    assert {"test-course", "rc-link-lost", "can-silence", "can-unplugged", "dac-failure"} <= names
    assert {"loop-stall"} == REALTIME
    assert {"teleop"} == INTERACTIVE


@pytest.mark.parametrize("path", FAULTS, ids=[path.stem for path in FAULTS])
def test_scenario_meets_its_expectations(path: Path) -> None:
    scenario = load_scenario(path)
    record = SimRun(default_sim_config(), scenario).run()
    failed = [verdict.expectation.describe() for verdict in record.verdicts if not verdict.passed]
    assert failed == []
    assert record.verdicts


def test_a_deadline_too_tight_fails() -> None:
    """The checker can fail: the same RC-loss scenario with a 50 ms deadline must not pass."""
    text = (SCENARIOS[0].parent / "rc-link-lost.toml").read_text(encoding="utf-8")
    assert "within_s = 0.110" in text
    tight = text.replace("within_s = 0.110", "within_s = 0.050")
    record = SimRun(default_sim_config(), parse_scenario(tight, "tight.toml")).run()
    verdict = next(v for v in record.verdicts if v.expectation.after == "rc lost")
    assert verdict.passed is False
    assert verdict.measured_s is not None
    assert verdict.measured_s > 0.050


def test_the_teleop_scenario_waits_in_stop_for_an_outside_computer() -> None:
    scenario = load_scenario(SCENARIOS[0].parent / "teleop.toml")
    run = SimRun(default_sim_config(), scenario, duration_s=2.0)
    run.run()
    senders = run.world.bus.bits_by_sender
    assert "hlc" not in senders  # the simulated computer never sent a command
    outputs = run.runtime.outputs
    assert outputs is not None
    assert outputs.mode.name == "STOP"
    # The switch moved into CAN before any computer sent: the refused arming latched CAN_LOST,
    # which the outside computer's re-enable edge clears.
    assert {cause.name for cause in outputs.causes} == {"CAN_LOST"}


def test_the_slope_scenario_fails_without_the_governor_or_the_grade() -> None:
    """speed-limit-slope has teeth: without the limit the slope carries the robot past it; and
    the grade is real: on the flat the unlimited robot passes the limit too, but not the margin."""
    scenario = load_scenario(SCENARIOS[0].parent / "speed-limit-slope.toml")
    unlimited = replace(default_sim_config(), limits=LimitsSection(None))
    record = SimRun(unlimited, scenario).run()
    failed = {verdict.expectation.describe() for verdict in record.verdicts if not verdict.passed}
    assert any(name.startswith("downhill at full throttle") for name in failed)
    flat = replace(
        scenario, events=tuple(event for event in scenario.events if event.kind != "world")
    )
    run = SimRun(unlimited, flat)
    run.run()
    assert 2.9 < run.record.top_speed_mps <= 3.0
