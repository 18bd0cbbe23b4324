"""`bywire verify`'s engine: random fault campaigns on one robot configuration, each judged by
the hazard oracle; a failing one shrunk to a short scenario that replays the failure.

Campaign `index` of seed `seed` is drawn from its own random source (`draw_bridge.draw_any`: a
share of them are bridge campaigns, the ROS 2 bridge as the computer), so a run is the same for
a given seed and budget however many processes share it, and any one campaign can be drawn again
alone (`sim/verify/draw.py` and `draw_bridge.py` say how campaigns are drawn).
"""

from __future__ import annotations

import builtins
import contextlib
import multiprocessing
import multiprocessing.connection
import signal
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass, field, replace
from multiprocessing.connection import Connection
from typing import Any

from bywire.background import OWNER
from bywire.build import picklable_compiled_dataclasses
from bywire.config import RobotConfig, default_sim_config
from bywire.sim.runner import SimRun
from bywire.sim.scenario import Expectation, Scenario, parse_scenario, scenario_toml
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
    hlc_refused: dict[str, int] = field(default_factory=dict)  # command frames never sent


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
        result.hlc_refused,
    )


# --- running campaigns on every core ---------------------------------------------------------

CRASH_DEATHS = 2
"""A campaign whose worker dies is run once more in a new worker; dying this many times makes it
a finding of its own (`Crash`), as on a cluster."""
HANG_S = 120.0
"""The default real time a campaign may run in its worker before it is killed as a hang."""
INTERRUPTING = frozenset({signal.SIGINT, signal.SIGTERM})
"""The signals that interrupt a run: Ctrl-C, and SIGTERM, which `bywire verify` takes alike."""
END_WAIT_S = 5.0  # how long an idle worker has to return at the end of a run before SIGTERM

_ROBOT: RobotConfig | None = None  # each worker's robot, set before the workers fork


@dataclass(frozen=True, slots=True)
class CampaignJob:
    """Which campaigns: those of `seed`, each `campaign_s` simulated seconds long."""

    seed: int
    campaign_s: float


@dataclass(frozen=True, slots=True)
class Crash:
    """A campaign that killed its worker `deaths` times (twice here and on a local cluster; on
    a cluster the user runs, its scheduler's allowed-failures + 1; None when it does not say): a
    finding of its own."""

    seed: int
    index: int
    deaths: int | None


@dataclass(frozen=True, slots=True)
class Hang:
    """A campaign still running after `limit_s` seconds of real time: killed with its worker, a
    finding of its own (a hung campaign is a real-time hang, so its limit is real time)."""

    seed: int
    index: int
    limit_s: float


Result = Outcome | Crash | Hang
"""What one campaign gives: its outcome, or the finding that it crashed or hung its worker."""


def run_indexed(robot: RobotConfig, job: CampaignJob, index: int) -> Outcome:
    """Campaign `index` of `job` on `robot`, drawn from its seed and index alone: the same
    outcome in whichever process, or on whichever machine, it runs."""
    return run_campaign(robot, draw_any(job.seed, index, job.campaign_s), index)


def _run_one(job: CampaignJob, index: int) -> Outcome:
    return run_indexed(_ROBOT if _ROBOT is not None else default_sim_config(), job, index)


def campaign_outcomes(
    robot: RobotConfig,
    job: CampaignJob,
    jobs: int,
    budget: int | None,
    until: float | None,
    *,
    limit_s: float | None = None,
) -> Generator[Result, None, None]:
    """Every campaign's result in index order: `budget` of them, or as many as start before the
    wall-clock time `until`. With `jobs` > 1, or a real-time limit `limit_s` per campaign, they
    run in forked worker processes (`_Workers`): a worker that dies is replaced, a campaign
    that killed its worker twice is a `Crash`, one over `limit_s` a `Hang`, and the run goes
    on. One job without a limit runs them here, in this process."""
    global _ROBOT  # noqa: PLW0603 - read by the forked workers
    _ROBOT = robot
    if jobs == 1 and limit_s is None:
        yield from _serial(job, budget, until)
        return
    picklable_compiled_dataclasses()  # a compiled build's campaigns and outcomes cross over
    workers = _Workers(jobs, job, limit_s)
    try:
        yield from workers.results(budget, until)
    finally:
        workers.end()


@dataclass(eq=False, slots=True)
class _Worker:
    """One forked worker: campaign indices go down its pipe, results come back."""

    process: Any  # multiprocessing's forked Process
    pipe: Connection
    index: int | None = None  # the campaign it runs, None when idle
    started_s: float = 0.0  # time.monotonic() when it was given `index`


class _Workers:
    """`jobs` forked worker processes, each started through the owner, each given one campaign
    at a time, so that whichever dies or hangs is known by its campaign."""

    def __init__(self, jobs: int, job: CampaignJob, limit_s: float | None) -> None:
        self._context = multiprocessing.get_context("fork")
        self._job = job
        self._limit_s = limit_s
        self._deaths: Counter[int] = Counter()
        self._again: deque[int] = deque()  # campaigns whose worker died once: run them first
        self._workers: list[_Worker] = []
        try:
            for _ in range(jobs):
                self._workers.append(self._start())
        except BaseException:  # interrupted while forking: those started end here
            self.end()
            raise

    def _start(self) -> _Worker:
        here, there = self._context.Pipe()
        # The child closes this side's ends, its own and the other workers': a worker then reads
        # the end of its pipe when this process is gone, however it went, and returns.
        ours = (here, *(worker.pipe for worker in self._workers))
        process = self._context.Process(
            target=_work, args=(there, self._job, ours), name="bywire-verify-worker", daemon=True
        )
        # Forked with Ctrl-C and SIGTERM blocked: until `_work` has set its own dispositions, a
        # signal to the whole group (a terminal, `timeout`, a service manager) would find the
        # parent's handlers in the child and end it with a traceback. Blocked, it waits there.
        blocked = threading.current_thread() is threading.main_thread()
        if blocked:
            previous = signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTING)
        try:
            OWNER.process(process)
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_SETMASK, previous)
        there.close()
        return _Worker(process, here)

    def results(self, budget: int | None, until: float | None) -> Iterator[Result]:
        ready: dict[int, Result] = {}
        released = 0
        issued = 0

        def next_index() -> int | None:
            nonlocal issued
            if self._again:
                return self._again.popleft()
            if budget is not None and issued >= budget:
                return None
            if budget is None and until is not None and time.monotonic() >= until:
                return None
            issued += 1
            return issued - 1

        while True:
            for worker in self._workers:
                if worker.index is None and (index := next_index()) is not None:
                    self._give(worker, index)
            busy = [worker for worker in self._workers if worker.index is not None]
            if not busy:
                break
            self._wait(busy)
            for position, worker in enumerate(self._workers):
                result = self._result(worker)
                if result is not None:
                    ready[result.index] = result
                # Replaced only once its campaign is accounted for: one that died between
                # `_result`'s look and this one is seen dead on the next round (its sentinel
                # wakes the wait at once); replaced here, its campaign was lost (both workers
                # killed at once, under load: the run ended without campaign 0).
                if worker.index is None and not worker.process.is_alive():
                    worker.process.join()
                    worker.pipe.close()
                    self._workers[position] = self._start()
            while released in ready:
                yield ready.pop(released)
                released += 1
        yield from (ready[index] for index in sorted(ready))

    def _give(self, worker: _Worker, index: int) -> None:
        worker.index, worker.started_s = index, time.monotonic()
        with contextlib.suppress(OSError):  # a worker gone already is noticed by its sentinel
            worker.pipe.send(index)

    def _wait(self, busy: list[_Worker]) -> None:
        timeout_s = None
        if self._limit_s is not None:
            first_s = min(worker.started_s for worker in busy) + self._limit_s
            timeout_s = max(0.0, first_s - time.monotonic())
        handles: list[Any] = [worker.pipe for worker in busy]
        handles += [worker.process.sentinel for worker in busy]
        multiprocessing.connection.wait(handles, timeout_s)

    def _result(self, worker: _Worker) -> Result | None:
        """What `worker` has to say about its campaign, if anything yet: its outcome (an error
        raised by the campaign is raised here), or a crash or a hang; None for a campaign that
        still runs, or one given again to another worker."""
        index = worker.index
        if index is None:
            return None
        if worker.pipe.poll():
            try:
                answer: Outcome | _Raised = worker.pipe.recv()
            except (EOFError, OSError):
                pass  # it died: below
            else:
                worker.index = None
                if isinstance(answer, _Raised):
                    raise answer.error
                return answer
        if not worker.process.is_alive():
            worker.index = None
            worker.process.join()
            worker.pipe.close()
            self._deaths[index] += 1
            if self._deaths[index] >= CRASH_DEATHS:
                return Crash(self._job.seed, index, self._deaths[index])
            self._again.append(index)
            return None
        if self._limit_s is not None and time.monotonic() - worker.started_s >= self._limit_s:
            worker.index = None
            worker.process.kill()
            worker.process.join()
            worker.pipe.close()
            return Hang(self._job.seed, index, self._limit_s)
        return None

    def end(self) -> None:
        """Every worker ended: an idle one asked to return, a busy one (the run interrupted)
        and any that does not return in time killed."""
        for worker in self._workers:
            if worker.index is None:
                with contextlib.suppress(OSError):
                    worker.pipe.send(None)
            else:
                worker.process.terminate()
        deadline_s = time.monotonic() + END_WAIT_S
        for worker in self._workers:
            worker.process.join(max(0.0, deadline_s - time.monotonic()))
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            worker.pipe.close()


@dataclass(frozen=True, slots=True)
class _Raised:
    """An error a campaign raised in its worker, sent back to be raised in the parent."""

    error: builtins.BaseException  # not `BaseException`: mypyc cannot load it at import (issue 43)


def _work(pipe: Connection, job: CampaignJob, parents: tuple[Connection, ...]) -> None:
    """A worker: run each campaign index sent until None, or until the parent is gone (the
    parent's ends of the pipes, inherited at the fork, closed here first). Ctrl-C is left to the
    parent, which ends the workers: one clean exit, no traceback from every process. SIGTERM
    is put back to its default, which ends the worker: the parent's own handler (`bywire
    verify` takes SIGTERM for Ctrl-C) is inherited by the fork."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTING)  # blocked by `_Workers._start`
    for end in parents:
        end.close()
    while True:
        try:
            index: int | None = pipe.recv()
        except (EOFError, OSError):
            return
        if index is None:
            return
        try:
            answer: Outcome | _Raised = _run_one(job, index)
        except Exception as error:
            answer = _Raised(error)
        try:
            pipe.send(answer)
        except OSError:  # the parent is gone
            return
        except Exception as error:  # an error that does not pickle: its text does
            pipe.send(_Raised(RuntimeError(f"campaign {index}: {error!r}")))


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
    fails_on_replay: bool | None = None  # its scenario, written and read back, run by `sim`


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
    result.fails_on_replay = fails_on_replay(robot, result.scenario)
    return result


def fails_on_replay(robot: RobotConfig, scenario: Scenario) -> bool:
    """Whether `scenario`, written as its file and read back, fails when `bywire sim
    --scenario` runs it: what a reproduction promises. A B3 finding once passed on replay,
    its condition weaker than the oracle's rule (`bywire verify --seed 1`, campaign 1903)."""
    written = parse_scenario(scenario_toml(scenario), f"{scenario.name}.toml")
    return not all(verdict.passed for verdict in SimRun(robot, written).run().verdicts)
