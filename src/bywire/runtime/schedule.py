"""Each periodic task's place in time and its statistics: the Python counterpart of Figure 30.

The rows themselves (thesis Table 1) are `bywire.task_table.SCHEDULE`.

Periodic tasks keep absolute deadlines: the next deadline is the previous one plus the period,
never "now plus the period", so the schedule cannot drift. A task that falls a whole period or
more behind skips the missed deadlines (no burst of catch-up runs) and counts them as overruns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from bywire.task_table import TaskSpec

JITTER_BIN_S = 10e-6
JITTER_BINS = 2000  # 0…20 ms in 10 µs bins; later starts land in the last bin


@dataclass(slots=True)
class TaskStats:
    """Runs, overruns, start jitter (late start against the deadline) and time spent."""

    runs: int = 0
    overruns: int = 0
    budget_exceeded: int = 0
    spent_s: float = 0.0
    max_jitter_s: float = 0.0
    jitter_bins: list[int] = field(default_factory=lambda: [0] * JITTER_BINS)

    def record(self, jitter_s: float, spent_s: float, budget_s: float) -> None:
        """Account one run that started `jitter_s` after its deadline and took `spent_s`."""
        self.runs += 1
        self.spent_s += spent_s
        self.max_jitter_s = max(self.max_jitter_s, jitter_s)
        index = min(int(max(jitter_s, 0.0) / JITTER_BIN_S), JITTER_BINS - 1)
        self.jitter_bins[index] += 1
        if spent_s > budget_s:
            self.budget_exceeded += 1

    def jitter_percentile_s(self, fraction: float) -> float:
        """Upper edge of the bin holding that fraction of runs, never above the maximum seen
        (0 when nothing ran)."""
        threshold = math.ceil(fraction * self.runs)
        seen = 0
        for index, count in enumerate(self.jitter_bins):
            seen += count
            if count and seen >= threshold:
                return min((index + 1) * JITTER_BIN_S, self.max_jitter_s)
        return 0.0


@dataclass(slots=True)
class PeriodicTask:
    """A task's place in time: its spec, next absolute deadline and statistics.

    The deadline is counted in whole periods from the first one (`first + ticks / rate`), never
    summed period by period: tasks whose rates divide each other then share their deadlines to
    the last bit (the 50 Hz task's every deadline is exactly a 100 Hz one), so they run in one
    pass of the loop, as on the robot, instead of a rounding error apart."""

    spec: TaskSpec
    next_deadline_s: float
    stats: TaskStats = field(default_factory=TaskStats)
    ticks: int = 0
    first_deadline_s: float = field(init=False)

    def __post_init__(self) -> None:
        self.first_deadline_s = self.next_deadline_s

    def due(self, now: float) -> bool:
        return now >= self.next_deadline_s

    def advance(self, now: float) -> None:
        """Move to the next deadline after `now`, counting each skipped one as an overrun."""
        rate_hz = self.spec.rate_hz
        self.ticks += 1
        self.next_deadline_s = self.first_deadline_s + self.ticks / rate_hz
        if now >= self.next_deadline_s:
            missed = math.floor((now - self.next_deadline_s) * rate_hz) + 1
            self.stats.overruns += missed
            self.ticks += missed
            self.next_deadline_s = self.first_deadline_s + self.ticks / rate_hz
