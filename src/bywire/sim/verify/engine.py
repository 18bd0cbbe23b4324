"""`bywire verify`'s engine: random fault campaigns on one robot configuration, each judged by
the hazard oracle; a failing one shrunk to a short scenario that replays the failure.

Campaign `index` of seed `seed` is drawn from its own random source (`draw_bridge.draw_any`: a
share of them are bridge campaigns, the ROS 2 bridge as the computer), so a run is the same for
a given seed and budget however many processes share it, and any one campaign can be drawn again
alone (`sim/verify/draw.py` and `draw_bridge.py` say how campaigns are drawn).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.pool
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any

from bywire.background import OWNER
from bywire.build import picklable_compiled_dataclasses
from bywire.config import RobotConfig, default_sim_config
from bywire.sim.scenario import Expectation, Scenario
from bywire.sim.verify.campaign import TAIL_S, VOCABULARY, Campaign, Step, compile_steps
from bywire.sim.verify.draw_bridge import draw_any

SHRINK_RUNS = 300  # at most this many campaigns to shrink one failure


@dataclass(frozen=True, slots=True)
class Finding:
    """One invariant broken: which, when (simulated seconds from the start) and what showed."""

    invariant: str
    time_s: float
    detail: str
    expected: dict[str, Any]  # what the hardware should have shown (expectation conditions)


@dataclass(slots=True)
class Outcome:
    """One campaign's result, small enough to send between processes."""

    index: int
    steps: list[Step]
    simulated_s: float
    events: int
    checks: int
    findings: list[Finding]
    transitions: set[str]
    bridge: bool = False  # a bridge campaign: the ROS 2 bridge was the computer (B1..B3 judged)


def run_campaign(robot: RobotConfig, steps: list[Step], index: int = 0) -> Outcome:
    """Play `steps` on `robot` with the oracle watching every pass."""
    result = Campaign(robot).run(steps)
    oracle = result.oracle
    findings = [Finding(v.invariant, v.time_s, v.detail, v.expected) for v in oracle.violations]
    return Outcome(
        index,
        steps,
        result.simulated_s,
        result.events,
        oracle.checks,
        findings,
        result.transitions,
        result.scenario.computer == "bridge",
    )


# --- running campaigns on every core ---------------------------------------------------------

BATCH_PER_JOB = 8  # campaigns handed out at a time per process when running for a duration

_ROBOT: RobotConfig | None = None  # each worker's robot, set before the pool forks


@dataclass(frozen=True, slots=True)
class CampaignJob:
    """Which campaigns: those of `seed`, each `campaign_s` simulated seconds long."""

    seed: int
    campaign_s: float


def _run_one(job: CampaignJob, index: int) -> Outcome:
    robot = _ROBOT if _ROBOT is not None else default_sim_config()
    return run_campaign(robot, draw_any(job.seed, index, job.campaign_s), index)


def _run_index(arguments: tuple[CampaignJob, int]) -> Outcome:
    return _run_one(*arguments)


def campaign_outcomes(
    robot: RobotConfig, job: CampaignJob, jobs: int, budget: int | None, until: float | None
) -> Iterator[Outcome]:
    """Every campaign's outcome as it finishes: `budget` of them, or as many as fit before the
    wall-clock time `until`."""
    global _ROBOT  # noqa: PLW0603 - read by the forked workers
    _ROBOT = robot
    if jobs == 1:
        yield from _serial(job, budget, until)
        return
    with _workers(jobs) as pool:
        if budget is not None:
            yield from pool.imap_unordered(_run_index, ((job, i) for i in range(budget)), 2)
            return
        start = 0
        while until is None or time.monotonic() < until:
            batch = range(start, start + jobs * BATCH_PER_JOB)
            yield from pool.imap_unordered(_run_index, ((job, i) for i in batch))
            start = batch.stop


@contextlib.contextmanager
def _workers(jobs: int) -> Iterator[multiprocessing.pool.Pool]:
    """A pool of `jobs` forked workers, owned: a run that ends any way ends them too."""
    picklable_compiled_dataclasses()  # a compiled build's campaigns and outcomes cross over
    pool = multiprocessing.get_context("fork").Pool(jobs, initializer=_ignore_interrupt)
    ended = threading.Event()

    def end(_wait_s: float | None) -> bool:
        pool.terminate()
        pool.join()
        ended.set()
        return True

    work = OWNER.adopt(
        "process", f"bywire-verify-workers ({jobs})", alive=lambda: not ended.is_set(), end=end
    )
    try:
        with pool:  # its exit terminates the workers
            yield pool
    finally:
        ended.set()
        OWNER.forget(work)


def _ignore_interrupt() -> None:
    """A worker leaves Ctrl-C to the parent, which ends the pool: one clean exit, no traceback
    from every process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _serial(job: CampaignJob, budget: int | None, until: float | None) -> Iterator[Outcome]:
    index = 0
    while (budget is None or index < budget) and (until is None or time.monotonic() < until):
        yield _run_one(job, index)
        index += 1


# --- shrinking ---------------------------------------------------------------------------------


@dataclass(slots=True)
class Shrinker:
    """Makes a failing campaign shorter and simpler while it still breaks `invariant`: first
    what follows the failure goes, then chunks of steps (halves, quarters, … single ones; a
    dropped step's wait is added to the next, so the others keep their times), then each value
    is replaced by a simpler one of its action's vocabulary, then waits are rounded."""

    robot: RobotConfig
    invariant: str
    max_runs: int = SHRINK_RUNS
    runs: int = 0
    on_run: Callable[[int], None] | None = None

    def fails(self, steps: list[Step]) -> Outcome | None:
        """The outcome when `steps` still break the invariant, else None."""
        if self.runs >= self.max_runs or not steps:
            return None
        self.runs += 1
        if self.on_run is not None:
            self.on_run(self.runs)
        outcome = run_campaign(self.robot, steps)
        broken = any(f.invariant == self.invariant for f in outcome.findings)
        return outcome if broken else None

    def shrink(self, steps: list[Step], failure_s: float) -> list[Step]:
        """The shortest, simplest steps found that still fail (at worst `steps` themselves)."""
        best = _until(steps, failure_s)
        if self.fails(best) is None:
            best = steps
        best = self._drop_chunks(best)
        best = self._simplify(best, _simpler_values)
        return self._simplify(best, _rounder_waits)

    def _drop_chunks(self, steps: list[Step]) -> list[Step]:
        size = max(1, len(steps) // 2)
        while True:
            start = 0
            while start < len(steps):
                candidate = _without(steps, start, size)
                if self.fails(candidate) is not None:
                    steps = candidate
                else:
                    start += size
            if size == 1:
                return steps
            size = max(1, size // 2)

    def _simplify(self, steps: list[Step], options: Callable[[Step], Iterator[Step]]) -> list[Step]:
        for position in range(len(steps)):
            for simpler in options(steps[position]):
                candidate = [*steps[:position], simpler, *steps[position + 1 :]]
                if self.fails(candidate) is not None:
                    steps = candidate
                    break
        return steps


def _until(steps: list[Step], failure_s: float) -> list[Step]:
    """The steps that happen no later than `failure_s`."""
    kept, at_s = [], 0.0
    for step in steps:
        at_s += step.delay_s
        if at_s > failure_s:
            break
        kept.append(step)
    return kept


def _without(steps: list[Step], start: int, size: int) -> list[Step]:
    """`steps` with `size` of them from `start` dropped; their waits go to the next one."""
    dropped = steps[start : start + size]
    rest = steps[start + size :]
    if rest:
        wait_s = round(sum(step.delay_s for step in dropped) + rest[0].delay_s, 6)
        rest = [replace(rest[0], delay_s=wait_s), *rest[1:]]
    return [*steps[:start], *rest]


def _simpler_values(step: Step) -> Iterator[Step]:
    values = VOCABULARY[step.action]
    if isinstance(values, range):
        value = int(step.value)  # type: ignore[call-overload]
        candidates: list[object] = [values.start, (values.start + value) // 2]
    elif step.value in values:
        candidates = list(values[: list(values).index(step.value)])  # listed simplest first
    else:
        candidates = list(values)  # a campaign's opening throttle is drawn from its own list
    for value in dict.fromkeys(candidates):
        if value != step.value:
            yield replace(step, value=value)


def _rounder_waits(step: Step) -> Iterator[Step]:
    for grid_s in (0.1, 0.01):
        rounded = round(round(step.delay_s / grid_s) * grid_s, 6)
        if rounded != step.delay_s and rounded > 0:
            yield replace(step, delay_s=rounded)


# --- a failure as a scenario -------------------------------------------------------------------


@dataclass(slots=True)
class Reproduction:
    """A shrunk failure: its steps, the scenario that replays it, and what broke."""

    steps: list[Step]
    scenario: Scenario
    finding: Finding
    shrink_runs: int = 0
    original_steps: int = 0
    notes: list[str] = field(default_factory=list)


def reproduction(
    robot: RobotConfig, steps: list[Step], finding: Finding, name: str
) -> Reproduction:
    """The scenario of `steps` with one expectation: the safe levels `finding.invariant` asks
    for, at the instant the oracle found them broken (so replaying it fails there)."""
    compiled = compile_steps(steps, robot, name=name)
    label = f"{finding.invariant} at {finding.time_s:.4f} s: {finding.detail}"
    expectation = Expectation(conditions=dict(finding.expected), at_s=finding.time_s, label=label)
    description = (
        f"found by bywire verify: {finding.invariant} broken ({finding.detail}); {len(steps)} steps"
    )
    scenario = replace(
        compiled,
        description=description,
        duration_s=max(compiled.duration_s, round(finding.time_s + TAIL_S, 6)),
        expectations=(expectation,),
    )
    return Reproduction(steps, scenario, finding)


def shrink_failure(
    robot: RobotConfig,
    outcome: Outcome,
    invariant: str,
    name: str,
    on_run: Callable[[int], None] | None = None,
) -> Reproduction:
    """Shrink the failing campaign `outcome` for `invariant` and make it a scenario."""
    first = next(f for f in outcome.findings if f.invariant == invariant)
    shrinker = Shrinker(robot, invariant, on_run=on_run)
    steps = shrinker.shrink(outcome.steps, first.time_s)
    final = run_campaign(robot, steps)
    found = next((f for f in final.findings if f.invariant == invariant), None)
    if found is None:  # shrinking ran out of runs before it failed again: keep the original
        steps, found = outcome.steps, first
    result = reproduction(robot, steps, found, name)
    result.shrink_runs = shrinker.runs
    result.original_steps = len(outcome.steps)
    return result
