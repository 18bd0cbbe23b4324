"""A scenario played on a robot file with the hazard oracle watching, as `bywire verify` plays
its campaigns: what the oracle found, and what the hardware showed on every pass."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.config import RobotConfig
from bywire.sim.observe import Observation
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from bywire.sim.verify.campaign import Campaign


@dataclass(frozen=True)
class Judged:
    """The invariants the oracle found broken (H1…), when each first broke, and the
    hardware's samples."""

    first_s: dict[str, float]
    samples: list[Observation]

    @property
    def found(self) -> frozenset[str]:
        return frozenset(self.first_s)

    def after(self, from_s: float) -> list[Observation]:
        """The samples from `from_s` on (never none: a test asks of a time the run reached)."""
        samples = [s for s in self.samples if s.time_s >= from_s]
        assert samples, f"the run ended before {from_s} s"
        return samples


def judged(robot: RobotConfig, scenario: str) -> Judged:
    runs: list[SimRun] = []
    result = Campaign(robot).run_scenario(parse_scenario(scenario, "judged"), prepare=runs.append)
    assert result.oracle.checks > 0
    first_s: dict[str, float] = {}
    for violation in result.oracle.violations:
        first_s.setdefault(violation.invariant.name, violation.time_s)
    return Judged(first_s, list(runs[0].record.samples))


def armed_in_rc(name: str, duration_s: float, *events: str, gear: str = "forward") -> str:
    """A scenario's text: the robot armed in RC by 0.26 s (the gear, the switch to STOP, then to
    RC with the stick at 0), then `events`, each an inline table such as
    `{ at_s = 1.0, rc = { throttle = 0.5 } }`."""
    preamble = (
        f'{{ at_s = 0.0, rc = {{ gear = "{gear}" }} }}',
        '{ at_s = 0.2, rc = { mode = "stop" } }',
        '{ at_s = 0.26, rc = { throttle = 0.0, mode = "rc" } }',
    )
    lines = ",\n    ".join((*preamble, *events))
    return f'name = "{name}"\nduration_s = {duration_s}\nevent = [\n    {lines},\n]\n'
