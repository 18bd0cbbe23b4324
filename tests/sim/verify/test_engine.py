"""The engine's worker processes (`--jobs N`, and any run with a real-time limit per campaign):
a worker killed mid-campaign is replaced and its campaign run again, a campaign that kills its
worker twice is a crash finding, one that runs past the limit a hang finding, and the run goes on
with the results a single process gives; nothing is left running (the leak check).

A campaign kills or hangs its worker through `engine.run_indexed`, patched here before the
workers fork: nothing in bywire reads a hook."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from bywire.config import default_sim_config
from bywire.sim.verify import engine
from bywire.sim.verify.engine import (
    CampaignJob,
    Crash,
    Hang,
    Outcome,
    Result,
    campaign_outcomes,
    run_indexed,
)

JOB = CampaignJob(seed=7, campaign_s=2.0)
BUDGET = 5
LIMIT_S = 2.0  # generous beside a 2 s simulated campaign, short for a test that waits it out
ROBOT = default_sim_config()
Campaign = Callable[[CampaignJob, int], None]


def _here() -> list[Outcome]:
    return [run_indexed(ROBOT, JOB, index) for index in range(BUDGET)]


def _run(
    monkeypatch: pytest.MonkeyPatch,
    before: Campaign,
    jobs: int = 2,
    limit_s: float | None = None,
) -> list[Result]:
    """The results of BUDGET campaigns on `jobs` workers, each worker calling `before` first."""
    real = engine.run_indexed

    def patched(robot: object, job: CampaignJob, index: int) -> Outcome:
        before(job, index)
        return real(ROBOT, job, index)

    monkeypatch.setattr(engine, "run_indexed", patched)  # before the workers fork
    return list(campaign_outcomes(ROBOT, JOB, jobs, BUDGET, None, limit_s=limit_s))


def _die_at(index: int, times: int, marks: Path) -> Campaign:
    """Campaign `index` kills its worker process the first `times` times it runs."""

    def before(_job: CampaignJob, at: int) -> None:
        if at != index:
            return
        deaths = len(list(marks.iterdir()))
        if deaths < times:
            (marks / str(deaths)).touch()
            os._exit(9)  # as a segfault in an extension would: no exception, no clean-up

    return before


def _hang_at(index: int) -> Campaign:
    def before(_job: CampaignJob, at: int) -> None:
        if at == index:
            threading.Event().wait()  # a deadlock: never returns

    return before


def test_workers_give_the_outcomes_of_one_process_in_index_order(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert _run(monkeypatch, lambda _job, _at: None, jobs=2, limit_s=LIMIT_S) == _here()


def test_a_campaign_that_kills_its_worker_once_is_run_again_and_the_run_completes(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    results = _run(monkeypatch, _die_at(2, 1, tmp_path))
    assert len(list(tmp_path.iterdir())) == 1  # it did die once
    assert results == _here()


def test_a_campaign_that_kills_its_worker_twice_is_a_crash_with_its_seed_and_index(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    results = _run(monkeypatch, _die_at(2, 5, tmp_path))
    here = _here()
    assert results == [*here[:2], Crash(JOB.seed, 2, 2), *here[3:]]
    assert len(list(tmp_path.iterdir())) == 2  # run twice, not more


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_hung_campaign_is_killed_at_the_limit_as_a_hang_and_the_run_goes_on(
    monkeypatch: pytest.MonkeyPatch, jobs: int
) -> None:
    results = _run(monkeypatch, _hang_at(1), jobs=jobs, limit_s=LIMIT_S)
    here = _here()
    assert results == [here[0], Hang(JOB.seed, 1, LIMIT_S), *here[2:]]


def test_every_worker_killed_at_once_still_ends_the_run(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A double fault: the campaigns in both workers kill them, each once."""
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    kill_0, kill_1 = _die_at(0, 1, first), _die_at(1, 1, second)

    def before(job: CampaignJob, at: int) -> None:
        kill_0(job, at)
        kill_1(job, at)

    assert _run(monkeypatch, before) == _here()


def test_an_error_a_campaign_raises_in_its_worker_is_raised_here(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def before(_job: CampaignJob, at: int) -> None:
        if at == 3:
            raise ValueError("campaign 3 broke")

    with pytest.raises(ValueError, match="campaign 3 broke"):
        _run(monkeypatch, before)


def test_a_worker_that_dies_between_two_looks_loses_no_campaign(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The race behind a failure under load: a worker found running by `_result` and dead by the
    next look was replaced with its campaign still on it, and the run ended without campaign 0.
    Here it dies exactly there, once: its campaign must be run again, as any death is."""
    original = engine._Workers._result
    died: list[int] = []

    def dying_after_the_look(workers: engine._Workers, worker: Any) -> Result | None:
        result = original(workers, worker)
        if result is None and worker.index == 0 and not died:
            died.append(worker.process.pid)
            worker.process.kill()
            worker.process.join()
        return result

    def slow_first(_job: CampaignJob, at: int) -> None:
        if at == 0 and not died:  # still running when the other worker's answer wakes the wait
            threading.Event().wait(0.5)

    monkeypatch.setattr(engine._Workers, "_result", dying_after_the_look)
    assert _run(monkeypatch, slow_first, jobs=2, limit_s=LIMIT_S) == _here()
    assert died
