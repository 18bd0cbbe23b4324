"""Virtual-time speed-up: a scenario's simulated duration over the wall time it took to run."""

from __future__ import annotations

import time
from dataclasses import dataclass

from bywire.config import RobotConfig
from bywire.sim.catalog import DEFAULT_SCENARIO, packaged_scenario
from bywire.sim.runner import SimRun


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
