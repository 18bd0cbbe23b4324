"""The watchdog: a thread outside the control loop that forces the safe outputs if the loop stalls.

The loop feeds the watchdog on every pass. If no feed comes for `limit_s` (default 200 ms,
R-WATCHDOG), the thread calls `on_trip` once, from its own thread, which writes the safe outputs
straight to the ports, and stays tripped until `reset()`: the runtime treats a trip as a hardware
fault (STOP, latched) and resets it only when the operator moves the mode switch to STOP. While
the loop is healthy the thread also tells systemd it is alive (WATCHDOG=1), so a process whose
loop is stuck is restarted by systemd's own watchdog too.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from bywire.background import OWNER

DEFAULT_LIMIT_S = 0.200
POLL_S = 0.005  # half a control period: the trip lands within limit + one period
NOTIFY_PERIOD_S = 0.100  # systemd needs a ping well within WatchdogSec, not every poll


class Watchdog:
    """Trips once when `feed()` has not been called for more than `limit_s`."""

    def __init__(
        self,
        on_trip: Callable[[], None],
        limit_s: float = DEFAULT_LIMIT_S,
        *,
        monotonic: Callable[[], float] = time.monotonic,
        notify: Callable[[str], None] | None = None,
    ) -> None:
        if limit_s <= 0:
            raise ValueError(f"watchdog limit must be > 0 s, got {limit_s}")
        self.limit_s = limit_s
        self.trips = 0
        self._on_trip = on_trip
        self._monotonic = monotonic
        self._notify = notify
        # Re-entrant: in the simulator a trip's safe writes run the virtual clock (a DAC transfer
        # that crawls advances it), whose timers check the watchdog again on the same thread; it
        # finds itself tripped and returns (issue 41: `verify --draw-robots` hung there).
        self._lock = threading.RLock()
        self._last_feed_s = monotonic()
        self._tripped = False
        self._stop = threading.Event()
        self._watcher: threading.Thread | None = None

    @property
    def tripped(self) -> bool:
        return self._tripped

    def feed(self) -> None:
        """The loop is alive (called on every pass of the control loop)."""
        self._last_feed_s = self._monotonic()

    def reset(self) -> None:
        """The operator acknowledged the trip; feeding restarts the count."""
        with self._lock:
            self._tripped = False
            self._last_feed_s = self._monotonic()

    def check(self) -> bool:
        """Trip if the loop has not fed in time; True while tripped. Safe from any thread."""
        with self._lock:
            if not self._tripped and self._monotonic() - self._last_feed_s > self.limit_s:
                self._tripped = True
                self.trips += 1
                self._on_trip()
            return self._tripped

    def start(self) -> None:
        """Run `check` from a daemon thread every control period (or faster for short limits)."""
        self._stop.clear()
        self._watcher = OWNER.thread(self._watch, name="bywire-watchdog", stop=self._stop.set)

    def stop(self) -> None:
        self._stop.set()
        if self._watcher is not None:
            self._watcher.join()
            self._watcher = None

    def _watch(self) -> None:
        next_notify_s = self._monotonic()
        while not self._stop.wait(min(POLL_S, self.limit_s / 4)):
            if self.check() or self._notify is None or self._monotonic() < next_notify_s:
                continue
            self._notify("WATCHDOG=1")
            next_notify_s = self._monotonic() + NOTIFY_PERIOD_S
