"""`bywire.bench.phases`: a task's jitter figures, p99.9 included, from the runtime's statistics."""

from __future__ import annotations

import pytest

from bywire.bench.phases import TaskFigures
from bywire.runtime.schedule import PeriodicTask, TaskStats
from bywire.task_table import TaskSpec, write_steering


def test_task_figures_carry_p99_p999_and_max_jitter() -> None:
    stats = TaskStats()
    for _ in range(1990):
        stats.record(0.000_055, 0.0001, 0.002)  # bin 50..60 µs
    for _ in range(8):
        stats.record(0.000_420, 0.0001, 0.002)  # bin 420..430 µs: inside p99.9 of 2000
    stats.record(0.002_500, 0.0001, 0.002)
    stats.record(0.003_100, 0.0001, 0.002)
    figures = TaskFigures.of(
        PeriodicTask(TaskSpec("steering", 100.0, 0.002, write_steering), 0.0), stats
    )
    assert figures.runs == 2000
    assert figures.jitter_p99_s == pytest.approx(60e-6)
    assert figures.jitter_p999_s == pytest.approx(430e-6)  # the 1998th run
    assert figures.jitter_max_s == pytest.approx(0.0031)
