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
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from tests.system.judged import Judged, judged

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


def played() -> Judged:
    return judged(FAST_DRIVING, SLOW_TRANSFERS_THEN_NAKS)


def _stopped_by(run: Judged) -> float:
    """When the drive was off and the spring brake on for good after the first NAK."""
    after = run.after(NAK_S)
    assert not after[-1].motors_enabled
    assert after[-1].ebrake_engaged
    driving = [s.time_s for s in after if s.motors_enabled or not s.ebrake_engaged]
    return max(driving, default=NAK_S)


def test_a_failing_dac_on_a_fast_task_with_slow_transfers_stops_within_the_requirement() -> None:
    run = played()
    assert run.found == set()
    armed = [s for s in run.after(0.5) if s.time_s < NAK_S]
    assert all(s.motors_enabled and not s.ebrake_engaged for s in armed)
    assert _stopped_by(run) - NAK_S < DAC_FAILURE_DEADLINE_S


def test_the_oracle_before_counted_the_writes_at_the_files_rate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The mistake, kept: the DAC taken to be written every millisecond flags the right robot."""
    original = OracleTiming.for_robot

    def at_the_files_rate(robot: RobotConfig) -> OracleTiming:
        return replace(original(robot), driving_period_s=0.001)

    monkeypatch.setattr(OracleTiming, "for_robot", at_the_files_rate)
    assert "H1" in played().found


def test_a_dac_failure_that_never_latches_is_still_found(monkeypatch: pytest.MonkeyPatch) -> None:
    """The teeth: the slower writes give the controller longer, not for ever."""
    monkeypatch.setattr(dac_health.DacHealth, "failing", property(lambda _health: False))
    run = played()
    assert any(s.motors_enabled for s in run.after(NAK_S + DAC_FAILURE_DEADLINE_S))
    assert "H1" in run.found
