"""Hand-over from the controller's loop thread to the UI thread: the latest snapshot, under a lock.

The feed observes the loop (`Runtime.on_cycle`) and takes a snapshot at most every `period_s` of
controller time, in the loop's thread, so nothing else ever reads the runtime's mutable state.
The UI thread only calls `latest()` and `status`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from bywire.dashboard.snapshot import DashboardSnapshot, snapshot
from bywire.runtime.app import Runtime

SNAPSHOT_PERIOD_S = 0.1  # 10 Hz: more than the screen's refresh, a small cost to the loop


class SnapshotFeed:
    """The latest `DashboardSnapshot` of `runtime`, and a status line once the run has ended."""

    def __init__(
        self,
        runtime: Runtime,
        *,
        period_s: float = SNAPSHOT_PERIOD_S,
        wall_clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self._runtime = runtime
        self._period_s = period_s
        self._wall_clock = wall_clock
        self._wall_started_s = wall_clock()
        self._next_s = -math.inf
        self._lock = threading.Lock()
        self._latest: DashboardSnapshot | None = None
        self._status: str | None = None
        self.taken = 0

    def attach(self) -> SnapshotFeed:
        """Observe the runtime's loop from now on."""
        self._runtime.on_cycle.append(self.observe)
        return self

    def observe(self, now: float, *, force: bool = False) -> None:
        """From the loop thread: take a snapshot if one is due (or `force`d)."""
        if (now < self._next_s and not force) or self._runtime.outputs is None:
            return
        wall_elapsed_s = self._wall_clock() - self._wall_started_s
        taken = snapshot(self._runtime, now, wall_elapsed_s)
        self._next_s = now + self._period_s
        with self._lock:
            self._latest = taken
            self.taken += 1

    def finish(self, status: str) -> None:
        """The run has ended (from the loop thread): say how, for the UI to show."""
        with self._lock:
            self._status = status

    def latest(self) -> DashboardSnapshot | None:
        """The newest snapshot (None before the first decision); safe from any thread."""
        with self._lock:
            return self._latest

    @property
    def status(self) -> str | None:
        """None while the controller runs; afterwards how the run ended."""
        with self._lock:
            return self._status
