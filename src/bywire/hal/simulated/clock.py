"""Clocks for the simulated robot: virtual time (as fast as possible, exact) and real time.

Both carry the simulator's own timers (the RC transmitter's next frame, the vehicle model's next
step, the simulated computer's next command). Simulated ports call `notify_input()` when they have
bytes or frames for the controller, which makes `wait_until` return at that instant, just as a
UART or CAN interrupt wakes the real controller.
"""

from __future__ import annotations

import heapq
import itertools
import time
from collections.abc import Callable

Callback = Callable[[], None]


class VirtualClock:
    """Discrete-event time: waiting jumps straight to the next timer; nothing ever sleeps.

    The timers are a heap of (time, sequence, callback): equal times run in the order they were
    set, so runs reproduce. The heap is the clock's own, read in place by `wait_until` (it runs
    about a million timers a minute of `bywire verify`: no method call per timer)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._now_s = start_s
        self._heap: list[tuple[float, int, Callback]] = []
        self._sequence = itertools.count()
        self._input_pending = False

    def now(self) -> float:
        return self._now_s

    def call_at(self, when_s: float, callback: Callback) -> None:
        """Run `callback` at `when_s` (at once on the next wait if that time has passed)."""
        heapq.heappush(self._heap, (when_s, next(self._sequence), callback))

    def notify_input(self) -> None:
        """An input port has data: the current or next `wait_until` returns now."""
        self._input_pending = True

    def wait_until(self, deadline_s: float) -> None:
        heap = self._heap
        while not self._input_pending:
            if not heap or heap[0][0] > deadline_s:
                self._now_s = max(self._now_s, deadline_s)
                return
            when_s, _, callback = heapq.heappop(heap)
            self._now_s = max(self._now_s, when_s)
            callback()
        self._input_pending = False

    def _next_time(self) -> float | None:
        return self._heap[0][0] if self._heap else None

    def _pop(self) -> tuple[float, Callback]:
        when_s, _, callback = heapq.heappop(self._heap)
        return when_s, callback

    def advance(self, duration_s: float) -> None:
        """Run every timer in the next `duration_s` (a write that hangs, and tests). Input that
        arrives meanwhile is not consumed: the loop's next `wait_until` returns at once, as a
        UART or CAN interrupt during a slow I2C transfer leaves the real controller's wake-up
        event set (`bywire.hal.linux.clock`), so a frame is acted on when the pass ends, not a
        tick later."""
        deadline_s = self.now() + duration_s
        while (next_s := self._next_time()) is not None and next_s <= deadline_s:
            when_s, callback = self._pop()
            self._now_s = max(self._now_s, when_s)
            callback()
        self._now_s = max(self._now_s, deadline_s)


class RealtimeClock(VirtualClock):
    """The same timers, paced by the wall clock: `bywire sim --realtime` and the benchmark."""

    def __init__(self, start_s: float = 0.0) -> None:
        super().__init__(start_s)
        self._offset_s = time.monotonic() - start_s

    def now(self) -> float:
        return time.monotonic() - self._offset_s

    def wait_until(self, deadline_s: float) -> None:
        while not self._input_pending:
            next_s = self._next_time()
            target_s = deadline_s if next_s is None else min(next_s, deadline_s)
            self._sleep_until(target_s)
            if next_s is None or next_s > deadline_s:
                return
            self._pop()[1]()
        self._input_pending = False
        self._run_overdue()

    def advance(self, duration_s: float) -> None:
        """As `VirtualClock.advance`, paced by the wall clock: input that arrives meanwhile
        wakes the loop's next wait."""
        deadline_s = self.now() + duration_s
        while (next_s := self._next_time()) is not None and next_s <= deadline_s:
            self._sleep_until(next_s)
            self._pop()[1]()
        self._sleep_until(deadline_s)

    def _run_overdue(self) -> None:
        """Everything already due happens before the loop looks (a frame that arrived while it
        was busy is in the receive buffer on a robot too), not one event per wake-up."""
        while (next_s := self._next_time()) is not None and next_s <= self.now():
            self._pop()[1]()

    def _sleep_until(self, target_s: float) -> None:
        remaining_s = target_s - self.now()
        if remaining_s > 0:
            time.sleep(remaining_s)


class ScaledRealtimeClock(RealtimeClock):
    """Paced by the wall clock at `speed` times real time (SITL's `--speed N`): one wall second
    is `speed` simulated seconds, so a team can watch a run in Foxglove at 5×."""

    def __init__(self, start_s: float = 0.0, speed: float = 1.0) -> None:
        if not speed > 0.0:
            raise ValueError(f"speed must be > 0, got {speed}")
        super().__init__(start_s)
        self.speed = speed
        self._start_s = start_s
        self._wall_start_s = time.monotonic()

    def now(self) -> float:
        return self._start_s + (time.monotonic() - self._wall_start_s) * self.speed

    def _sleep_until(self, target_s: float) -> None:
        remaining_s = (target_s - self.now()) / self.speed
        if remaining_s > 0:
            time.sleep(remaining_s)
