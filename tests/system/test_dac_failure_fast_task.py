"""A failing DAC on a fast driving task with slow, legal transfers (docs/SAFETY.md row 79, found
by `bywire verify --draw-robots 12 --budget 1200 --seed 8`, file 3, campaign 12, H1): a legal
`tasks.driving_rate_hz = 1000`, every DAC transfer taking 2 ms (ordinary, within the file's
3.5 ms budget), then every other write NAKed. A driving pass with its two transfers outlasts the
1 ms period, so the DAC is written every few ms, not every ms; the controller stopped 16 ms after
the first NAK, well within R-DAC-FAULT's 60 ms. The oracle counted the failing writes at the
file's 1 kHz (six periods: 6 ms) and flagged H1. It now takes the DAC to be written no more often
than a pass within its budget ends."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.config import RobotConfig, parse_config
from bywire.config.deadlines import DAC_FAILURE_DEADLINE_S
from bywire.control import dac_health
from bywire.sim.observe import Observation
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from bywire.sim.verify.campaign import Campaign
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming

FAST_DRIVING = parse_config("[tasks]\ndriving_rate_hz = 1000\n", "fast-driving")
NAK_S = 1.0
SLOW_TRANSFERS_THEN_NAKS = f"""
name = "fast-driving-task"
duration_s = 1.6
event = [
    {{ at_s = 0.0, rc = {{ gear = "forward" }} }},
    {{ at_s = 0.2, rc = {{ mode = "stop" }} }},
    {{ at_s = 0.26, rc = {{ throttle = 0.0, mode = "rc" }} }},
    {{ at_s = 0.5, fault = "dac_slow", stall_s = 0.002 }},
    {{ at_s = {NAK_S}, fault = "dac_nak_alternate" }},
]
"""


def judged() -> tuple[set[str], list[Observation]]:
    runs: list[SimRun] = []
    result = Campaign(FAST_DRIVING).run_scenario(
        parse_scenario(SLOW_TRANSFERS_THEN_NAKS, "fast"), prepare=runs.append
    )
    assert result.oracle.checks > 0
    found = {violation.invariant.name for violation in result.oracle.violations}
    return found, list(runs[0].record.samples)


def _stopped_by(samples: list[Observation]) -> float:
    """When the drive was off and the spring brake on for good after the first NAK."""
    after = [s for s in samples if s.time_s >= NAK_S]
    assert after
    assert not after[-1].motors_enabled
    assert after[-1].ebrake_engaged
    driving = [s.time_s for s in after if s.motors_enabled or not s.ebrake_engaged]
    return max(driving, default=NAK_S)


def test_a_failing_dac_on_a_fast_task_with_slow_transfers_stops_within_the_requirement() -> None:
    found, samples = judged()
    assert found == set()
    armed = [s for s in samples if 0.5 <= s.time_s < NAK_S]
    assert armed
    assert all(s.motors_enabled and not s.ebrake_engaged for s in armed)
    assert _stopped_by(samples) - NAK_S < DAC_FAILURE_DEADLINE_S


def test_the_oracle_before_counted_the_writes_at_the_files_rate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The mistake, kept: the DAC taken to be written every millisecond flags the right robot."""
    original = OracleTiming.for_robot

    def at_the_files_rate(robot: RobotConfig) -> OracleTiming:
        return replace(original(robot), driving_period_s=0.001)

    monkeypatch.setattr(OracleTiming, "for_robot", at_the_files_rate)
    found, _ = judged()
    assert "H1" in found


def test_a_dac_failure_that_never_latches_is_still_found(monkeypatch: pytest.MonkeyPatch) -> None:
    """The teeth: the slower writes give the controller longer, not for ever."""
    monkeypatch.setattr(dac_health.DacHealth, "failing", property(lambda _health: False))
    found, samples = judged()
    assert any(s.motors_enabled for s in samples if s.time_s > NAK_S + DAC_FAILURE_DEADLINE_S)
    assert "H1" in found
