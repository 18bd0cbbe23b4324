"""Schedule statistics at their exact edges: budget, last jitter bin, overruns accumulate."""

from __future__ import annotations

from bywire.runtime.schedule import JITTER_BINS, PeriodicTask, TaskSpec, TaskStats

QUARTER = TaskSpec("quarter", 4.0, 0.01)  # a 0.25 s period, exact in binary


def test_a_run_that_takes_exactly_its_budget_is_within_it() -> None:
    stats = TaskStats()
    stats.record(0.0, 0.25, 0.25)
    assert stats.budget_exceeded == 0


def test_every_run_over_budget_is_counted() -> None:
    stats = TaskStats()
    stats.record(0.0, 0.5, 0.25)
    stats.record(0.0, 0.5, 0.25)
    assert stats.budget_exceeded == 2


def test_a_very_late_start_lands_in_the_last_jitter_bin() -> None:
    stats = TaskStats()
    stats.record(10.0, 0.0, 1.0)
    assert stats.jitter_bins[JITTER_BINS - 1] == 1
    assert sum(stats.jitter_bins) == 1


def test_finishing_exactly_one_period_late_skips_that_deadline_as_an_overrun() -> None:
    task = PeriodicTask(QUARTER, next_deadline_s=0.0)
    task.advance(0.25)
    assert task.next_deadline_s == 0.5
    assert task.stats.overruns == 1


def test_overruns_accumulate_over_separate_late_runs() -> None:
    task = PeriodicTask(QUARTER, next_deadline_s=0.0)
    task.advance(0.3)  # one deadline missed
    task.advance(1.1)  # two more missed
    assert task.stats.overruns == 3
