"""What simulated devices need from a clock, and a drift-free periodic timer built on it.

Simulated devices schedule themselves on the clock (``call_at``) and never sleep or spawn threads,
so the same device runs on a ``VirtualClock`` (as fast as possible) and a ``RealtimeClock``.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Protocol


class SimClock(Protocol):
    """The part of ``VirtualClock`` / ``RealtimeClock`` a simulated device uses."""

    def now(self) -> float:
        """Seconds on the simulation's time line."""
        ...

    def call_at(self, when_s: float, callback: Callable[[], None]) -> None:
        """Run ``callback`` at ``when_s``."""
        ...

    def notify_input(self) -> None:
        """Wake the controller's ``wait_until``: an input port has data."""
        ...


class PeriodicTimer:
    """Calls ``callback(tick_s)`` at ``first_s + k * period_s``: absolute deadlines, no drift.

    ``tick_s`` is the scheduled time (on a RealtimeClock the call may come a little later).
    ``stop()`` cancels the pending tick; a later ``start()`` begins a fresh series, and a tick
    left over from an earlier series is ignored, so a timer never runs twice per period.
    """

    def __init__(self, clock: SimClock, period_s: float, callback: Callable[[float], None]) -> None:
        if not period_s > 0.0:
            raise ValueError(f"period_s must be > 0, got {period_s}")
        self._clock = clock
        self._period_s = period_s
        self._callback = callback
        self._series = 0
        self._running = False
        self._first_s = 0.0
        self._ticks = 0

    @property
    def period_s(self) -> float:
        """Time between ticks."""
        return self._period_s

    @property
    def running(self) -> bool:
        """True between ``start()`` and ``stop()``."""
        return self._running

    @property
    def ticks(self) -> int:
        """Ticks run since the latest ``start()``."""
        return self._ticks

    def start(self, first_s: float | None = None) -> None:
        """Begin ticking at ``first_s`` (default: now); restarts a running timer."""
        self._series += 1
        self._running = True
        self._first_s = self._clock.now() if first_s is None else first_s
        self._ticks = 0
        self._schedule(self._series)

    def stop(self) -> None:
        """Stop ticking; the pending tick is ignored."""
        self._series += 1
        self._running = False

    def _schedule(self, series: int) -> None:
        when_s = self._first_s + self._ticks * self._period_s
        self._clock.call_at(when_s, partial(self._tick, series, when_s))

    def _tick(self, series: int, tick_s: float) -> None:
        if series != self._series:
            return
        self._ticks += 1
        self._schedule(series)
        self._callback(tick_s)
