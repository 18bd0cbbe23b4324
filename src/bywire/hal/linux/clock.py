"""The real-time clock port: monotonic time, and a wait that input threads cut short."""

from __future__ import annotations

import threading
import time


class LinuxClock:
    """`Clock` on `time.monotonic`; reader threads call `notify_input()` when data arrives.

    `wait_until` returns at the deadline or as soon as `notify_input()` was called since the
    previous wait returned, so an input that arrives while the loop is busy is not missed.
    """

    def __init__(self) -> None:
        self._input = threading.Event()

    def now(self) -> float:
        return time.monotonic()

    def notify_input(self) -> None:
        """Thread-safe: an input port has data; the current or next wait returns now."""
        self._input.set()

    def wait_until(self, deadline_s: float) -> None:
        # Loop: a timed wait may come back a hair early; only input may end it before the deadline.
        while (timeout_s := deadline_s - time.monotonic()) > 0.0:
            if self._input.wait(timeout_s):
                break
        # Cleared before the caller reads its ports: data arriving after this wakes the next wait.
        self._input.clear()
