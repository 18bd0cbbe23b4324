"""Schedule table and task statistics: Table 1 rates, absolute deadlines, overruns, percentiles."""

from __future__ import annotations

import pytest

from bywire.runtime.schedule import JITTER_BIN_S, SCHEDULE, PeriodicTask, TaskSpec, TaskStats


def test_schedule_is_table_1() -> None:
    rates = {spec.name: spec.rate_hz for spec in SCHEDULE}
    assert rates == {
        "steering": 100.0,
        "driving": 100.0,
        "hydrobrake": 100.0,
        "can_tx": 50.0,
        "lights": 20.0,
    }
    assert all(spec.budget_s < spec.period_s for spec in SCHEDULE)


def test_deadlines_are_absolute_and_do_not_drift() -> None:
    task = PeriodicTask(TaskSpec("t", 100.0, 0.001), next_deadline_s=0.0)
    for tick in range(1000):
        task.advance(now=tick * 0.01 + 0.004)  # each run starts 4 ms late
    assert task.next_deadline_s == pytest.approx(10.0)
    assert task.stats.overruns == 0


def test_missed_periods_are_skipped_and_counted() -> None:
    task = PeriodicTask(TaskSpec("t", 100.0, 0.001), next_deadline_s=1.0)
    task.advance(now=1.035)  # ran 35 ms late: deadlines 1.01, 1.02, 1.03 missed
    assert task.stats.overruns == 3
    assert task.next_deadline_s == pytest.approx(1.04)
    assert not task.due(1.0399)
    assert task.due(1.04)


def test_stats_percentiles_and_budget() -> None:
    stats = TaskStats()
    for _ in range(99):
        stats.record(jitter_s=0.00005, spent_s=0.0001, budget_s=0.001)
    stats.record(jitter_s=0.0031, spent_s=0.002, budget_s=0.001)
    assert stats.runs == 100
    assert stats.jitter_percentile_s(0.5) == pytest.approx(60e-6)
    assert stats.jitter_percentile_s(0.99) == pytest.approx(60e-6)
    assert stats.jitter_percentile_s(1.0) == pytest.approx(3.1e-3, abs=JITTER_BIN_S)
    assert stats.max_jitter_s == pytest.approx(0.0031)
    assert stats.budget_exceeded == 1
    assert stats.spent_s == pytest.approx(99 * 0.0001 + 0.002)


def test_empty_stats_report_zero() -> None:
    assert TaskStats().jitter_percentile_s(0.99) == 0.0
