"""Schedule table and task statistics: Table 1 rates, absolute deadlines, overruns, percentiles."""

from __future__ import annotations

import subprocess
import sys

import pytest

from bywire.config import parse_config
from bywire.config.consistency import CONTROL_TASKS
from bywire.errors import ConfigError
from bywire.runtime.schedule import JITTER_BIN_S, JITTER_BINS, PeriodicTask, TaskStats
from bywire.runtime.settings import RuntimeConfig
from bywire.task_table import SCHEDULE, TASK_NAMES, TaskSpec, write_lights

TABLE_1 = {"steering": 100.0, "driving": 100.0, "hydrobrake": 100.0, "can_tx": 50.0, "lights": 20.0}


def test_schedule_holds_table_1() -> None:
    rates = {spec.name: spec.rate_hz for spec in SCHEDULE}
    assert {name: rates.get(name) for name in TABLE_1} == TABLE_1
    assert all(spec.budget_s < spec.period_s for spec in SCHEDULE)


def test_deadlines_are_absolute_and_do_not_drift() -> None:
    task = PeriodicTask(TaskSpec("t", 100.0, 0.001, write_lights), next_deadline_s=0.0)
    for tick in range(1000):
        task.advance(now=tick * 0.01 + 0.004)  # each run starts 4 ms late
    assert task.next_deadline_s == pytest.approx(10.0)
    assert task.stats.overruns == 0


def test_missed_periods_are_skipped_and_counted() -> None:
    task = PeriodicTask(TaskSpec("t", 100.0, 0.001, write_lights), next_deadline_s=1.0)
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


# Tests added after mutation testing (docs/mutation.md). Schedule statistics at their exact edges:
# budget, last jitter bin, overruns accumulate.


QUARTER = TaskSpec("quarter", 4.0, 0.01, write_lights)  # a 0.25 s period, exact in binary


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


def test_the_schedule_table_rows_carry_their_tasks_and_the_configuration_overrides_by_name() -> (
    None
):
    assert all(callable(spec.run) for spec in SCHEDULE)
    assert len(TASK_NAMES) == len(set(TASK_NAMES))
    assert set(CONTROL_TASKS) <= set(TASK_NAMES)
    robot = parse_config("[tasks]\nlights_rate_hz = 10")
    rates = {spec.name: spec.rate_hz for spec in RuntimeConfig.from_robot(robot).schedule}
    assert rates == {**{spec.name: spec.rate_hz for spec in SCHEDULE}, "lights": 10.0}


def test_a_task_name_the_schedule_does_not_have_fails_at_load() -> None:
    with pytest.raises(ConfigError, match=r"tasks\.light_rate_hz"):
        parse_config("[tasks]\nlight_rate_hz = 10")


def test_the_configuration_reads_the_schedule_without_loading_the_codecs() -> None:
    # The table's rows name their task functions; importing them must stay light, or every
    # command that only reads a robot file pays for cantools and the DBC.
    code = "import sys, bywire.config; print('cantools' in sys.modules)"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "False"
