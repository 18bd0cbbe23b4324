"""Virtual time: the test course's speed-up (simulated over wall time), and how many of `bywire
verify`'s campaigns run per minute on every core."""

from __future__ import annotations

import time
from dataclasses import dataclass

from bywire.config import RobotConfig
from bywire.sim.catalog import DEFAULT_SCENARIO, packaged_scenario
from bywire.sim.runner import SimRun
from bywire.sim.verify.draw import CAMPAIGN_S
from bywire.sim.verify.engine import CampaignJob, Outcome, campaign_outcomes


@dataclass(frozen=True, slots=True)
class SpeedupResult:
    """How long a scenario ran in simulated and in wall time, and how its checks fared."""

    scenario: str
    scenario_duration_s: float
    simulated_s: float
    wall_s: float
    expectations_passed: int
    expectations_total: int

    @property
    def speedup(self) -> float:
        return self.simulated_s / self.wall_s


def measure_speedup(
    robot: RobotConfig, scenario_name: str = DEFAULT_SCENARIO, duration_s: float | None = None
) -> SpeedupResult:
    """Run the packaged scenario (to ``duration_s`` if given) in virtual time and time it."""
    scenario = packaged_scenario(scenario_name)
    started_s = time.perf_counter()
    run = SimRun(robot, scenario, duration_s=duration_s)
    record = run.run()
    wall_s = time.perf_counter() - started_s
    return SpeedupResult(
        scenario=scenario.name,
        scenario_duration_s=scenario.duration_s,
        simulated_s=run.duration_s,
        wall_s=wall_s,
        expectations_passed=sum(verdict.passed is True for verdict in record.verdicts),
        expectations_total=len(record.verdicts),
    )


@dataclass(frozen=True, slots=True)
class VerifyRateResult:
    """How many `bywire verify` campaigns ran in how long, on how many processes."""

    campaigns: int
    campaign_s: float
    jobs: int
    wall_s: float
    simulated_s: float

    @property
    def per_minute(self) -> float:
        return self.campaigns / self.wall_s * 60.0


def measure_verify_rate(
    robot: RobotConfig, campaigns: int, jobs: int, campaign_s: float = CAMPAIGN_S
) -> VerifyRateResult:
    """Run `campaigns` of `bywire verify`'s campaigns (seed 0) on `jobs` processes, timed."""
    started_s = time.perf_counter()
    outcomes = list(campaign_outcomes(robot, CampaignJob(0, campaign_s), jobs, campaigns, None))
    wall_s = time.perf_counter() - started_s
    simulated_s = sum(o.simulated_s for o in outcomes if isinstance(o, Outcome))  # a crash has none
    return VerifyRateResult(len(outcomes), campaign_s, jobs, wall_s, simulated_s)
