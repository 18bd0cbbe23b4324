"""Where the tail comes from: what the controller's thread was doing while a late command waited.

`bywire bench --probe` runs the session on a `ProbedClock`. It samples three counters of the
controller's thread at every boundary of its time: when a wait starts (the controller's pass has
ended, the simulator runs), when a sleep starts and ends, and when the wait returns (a pass
starts):

* the clock (``time.monotonic``, the simulation clock's base),
* the thread's CPU time (``CLOCK_THREAD_CPUTIME_ID``),
* its **run delay**, the time it was runnable but waiting for a CPU (the second field of
  ``/proc/thread-self/schedstat``; zero where the kernel does not provide it).

``gc.callbacks`` time every collection. A late interval (a command's completion to the DAC write
that carried it) is then split into parts that add up to its length:

``gc``          collections inside it (taken out of the CPU of the segment they ran in)
``runqueue``    runnable but not running: the scheduler gave the CPU to another process/thread
``wake``        asleep past the timer's instant, not runnable (timer slack, wake-up path)
``blocked``     awake, off the CPU, not runnable: waiting for the GIL (another Python thread)
``controller``  the thread's CPU in the controller's passes
``simulator``   its CPU in the simulator's callbacks (bus, flood, devices, vehicle, the bench)

The probe costs about 2 µs per sample and keeps every sample (~30 MB for two 60 s phases with
the bus flooded), so a probed run's CPU and memory figures are not the benchmark's.
"""

from __future__ import annotations

import bisect
import gc
import os
import time
from array import array
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from bywire.bench.clocks import MeteredRealtimeClock

SCHEDSTAT = "/proc/thread-self/schedstat"
CONTROLLER, SIMULATOR, ASLEEP = 0, 1, 2
PARTS = ("gc", "runqueue", "wake", "blocked", "controller", "simulator")
NS = 1e-9


class ThreadCounters:
    """The calling thread's CPU time and run delay, read in about a microsecond each."""

    def __init__(self, path: str = SCHEDSTAT) -> None:
        try:
            self._fd: int | None = os.open(path, os.O_RDONLY)
        except OSError:
            self._fd = None  # no schedstat: run delay reads as zero

    @property
    def has_run_delay(self) -> bool:
        return self._fd is not None

    def run_delay_s(self) -> float:
        """Seconds this thread has waited on a run queue since it started (0 without schedstat).

        The file is opened by the thread that reads it: /proc/thread-self names the opener.
        """
        if self._fd is None:
            return 0.0
        fields = os.pread(self._fd, 80, 0).split()
        return int(fields[1]) * NS

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


@dataclass(slots=True)
class Timeline:
    """Samples of (time, thread CPU, run delay) and what the thread did until the next sample;
    and every garbage collection's start, end and generation. Times on the simulation clock."""

    times_s: array[float] = field(default_factory=lambda: array("d"))
    cpu_s: array[float] = field(default_factory=lambda: array("d"))
    run_delay_s: array[float] = field(default_factory=lambda: array("d"))
    states: array[int] = field(default_factory=lambda: array("b"))
    gc_starts_s: array[float] = field(default_factory=lambda: array("d"))
    gc_ends_s: array[float] = field(default_factory=lambda: array("d"))
    gc_generations: array[int] = field(default_factory=lambda: array("b"))
    wake_deadlines_s: array[float] = field(default_factory=lambda: array("d"))
    wakes_s: array[float] = field(default_factory=lambda: array("d"))

    def late_wakes(self, span: tuple[float, float]) -> list[tuple[float, float]]:
        """(deadline, return) of every wait that returned after its deadline, deadline in span:
        how late the loop started a pass due at that deadline (the tasks' jitter)."""
        return [
            (deadline, woke)
            for deadline, woke in zip(self.wake_deadlines_s, self.wakes_s, strict=True)
            if woke > deadline and span[0] <= deadline < span[1]
        ]

    def add(self, time_s: float, cpu_s: float, run_delay_s: float, state: int) -> None:
        self.times_s.append(time_s)
        self.cpu_s.append(cpu_s)
        self.run_delay_s.append(run_delay_s)
        self.states.append(state)

    def gc_within(self, start_s: float, end_s: float) -> float:
        """Seconds of garbage collection inside [start_s, end_s]."""
        total = 0.0
        first = max(bisect.bisect_left(self.gc_ends_s, start_s), 0)
        for index in range(first, len(self.gc_starts_s)):
            began, ended = self.gc_starts_s[index], self.gc_ends_s[index]
            if began >= end_s:
                break
            total += max(0.0, min(ended, end_s) - max(began, start_s))
        return total

    def explain(self, start_s: float, end_s: float) -> dict[str, float]:
        """``end_s - start_s`` split into `PARTS` (seconds); empty outside the samples."""
        parts = dict.fromkeys(PARTS, 0.0)
        times = self.times_s
        first = max(bisect.bisect_right(times, start_s) - 1, 0)
        for index in range(first, len(times) - 1):
            seg_start, seg_end = times[index], times[index + 1]
            if seg_start >= end_s:
                break
            overlap = min(seg_end, end_s) - max(seg_start, start_s)
            if overlap <= 0 or seg_end <= seg_start:
                continue
            share = overlap / (seg_end - seg_start)
            cpu = (self.cpu_s[index + 1] - self.cpu_s[index]) * share
            queued = (self.run_delay_s[index + 1] - self.run_delay_s[index]) * share
            collected = min(self.gc_within(max(seg_start, start_s), min(seg_end, end_s)), cpu)
            off_cpu = max(overlap - cpu - queued, 0.0)
            parts["gc"] += collected
            parts["runqueue"] += queued
            state = self.states[index]
            parts["wake" if state == ASLEEP else "blocked"] += off_cpu
            if state != ASLEEP:
                parts["controller" if state == CONTROLLER else "simulator"] += cpu - collected
        return parts


class ProbedClock(MeteredRealtimeClock):
    """The benchmark's real-time clock, sampling the controller thread's counters as it goes.

    Call `start` from the controller's thread before the session and `stop` after it.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        super().__init__(start_s)
        self.timeline = Timeline()
        self._counters: ThreadCounters | None = None
        self._gc_started_s = 0.0

    @property
    def has_run_delay(self) -> bool:
        return self._counters is not None and self._counters.has_run_delay

    def start(self) -> None:
        self._counters = ThreadCounters()
        gc.callbacks.append(self._on_gc)
        self._sample(CONTROLLER)

    def stop(self) -> None:
        if self._on_gc in gc.callbacks:
            gc.callbacks.remove(self._on_gc)
        if self._counters is not None:
            self._sample(CONTROLLER)
            self._counters.close()
            self._counters = None

    def _sample(self, state: int) -> None:
        counters = self._counters
        if counters is not None:
            self.timeline.add(self.now(), time.thread_time(), counters.run_delay_s(), state)

    def _on_gc(self, phase: str, info: dict[str, Any]) -> None:
        now = self.now()
        if phase == "start":
            self._gc_started_s = now
            return
        timeline = self.timeline
        timeline.gc_starts_s.append(self._gc_started_s)
        timeline.gc_ends_s.append(now)
        timeline.gc_generations.append(int(info["generation"]))

    def wait_until(self, deadline_s: float) -> None:
        self._sample(SIMULATOR)
        try:
            super().wait_until(deadline_s)
        finally:
            self._sample(CONTROLLER)
            if self._counters is not None:
                self.timeline.wake_deadlines_s.append(deadline_s)
                self.timeline.wakes_s.append(self.timeline.times_s[-1])

    def _sleep_until(self, target_s: float) -> None:
        self._sample(ASLEEP)
        try:
            super()._sleep_until(target_s)
        finally:
            self._sample(SIMULATOR)


@dataclass(frozen=True, slots=True)
class GcFigures:
    """Collections of one generation inside a stretch of time."""

    generation: int
    count: int
    total_s: float
    max_s: float


@dataclass(frozen=True, slots=True)
class PhaseTail:
    """One phase's collections and the tails of its command paths and of its wake-ups."""

    name: str
    gc: tuple[GcFigures, ...]
    tails: tuple[TailFigures, ...]


@dataclass(frozen=True, slots=True)
class TailFigures:
    """The latencies of one command path above ``threshold_s``, split into `PARTS`."""

    path: str
    threshold_s: float
    samples: int
    late: int
    parts_s: dict[str, float]
    dominant: dict[str, int]
    worst: tuple[tuple[float, float, dict[str, float]], ...]
    """The longest late intervals: (length, start on the simulation clock, parts)."""


def gc_figures(timeline: Timeline, span: tuple[float, float]) -> list[GcFigures]:
    """Per generation: how many collections started in ``span``, their total and longest."""
    durations: dict[int, list[float]] = {0: [], 1: [], 2: []}
    for began, ended, generation in zip(
        timeline.gc_starts_s, timeline.gc_ends_s, timeline.gc_generations, strict=True
    ):
        if span[0] <= began < span[1]:
            durations.setdefault(generation, []).append(ended - began)
    return [
        GcFigures(generation, len(spent), sum(spent), max(spent, default=0.0))
        for generation, spent in sorted(durations.items())
    ]


def explain_tail(
    timeline: Timeline,
    path: str,
    intervals: Sequence[tuple[float, float]],
    threshold_s: float,
    worst: int = 5,
) -> TailFigures:
    """Split every interval longer than ``threshold_s`` into its parts; the sums, the count of
    intervals each part dominates, and the ``worst`` longest with their parts."""
    late = [(start, end) for start, end in intervals if end - start > threshold_s]
    totals = dict.fromkeys(PARTS, 0.0)
    dominant = dict.fromkeys(PARTS, 0)
    explained: list[tuple[float, float, dict[str, float]]] = []
    for start, end in late:
        parts = timeline.explain(start, end)
        for name, seconds in parts.items():
            totals[name] += seconds
        dominant[max(parts, key=parts.__getitem__)] += 1
        explained.append((end - start, start, parts))
    explained.sort(key=lambda item: item[0], reverse=True)
    return TailFigures(
        path, threshold_s, len(intervals), len(late), totals, dominant, tuple(explained[:worst])
    )
