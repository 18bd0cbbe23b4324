"""The one hand-over from the controller's loop to the telemetry writer: a bounded queue.

The loop only appends; a full queue drops its oldest item and counts it, so a slow or stuck
consumer loses messages, never the loop's time. On virtual time there is no loop time to lose:
there the outbox may be told to `wait` for room instead, so that a recording is complete and the
same on every machine.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Generic, TypeVar

Item = TypeVar("Item")

DEFAULT_CAPACITY = 4096  # 80 s of state at 50 Hz, or a few seconds of a busy CAN bus


class Outbox(Generic[Item]):
    """A bounded FIFO between one producer (the loop) and one consumer: the writer's thread, or
    on real time the loop itself, which takes with `take_ready` and ships to the writer's process.

    `put` never blocks unless `wait_when_full` (virtual time only); `take` blocks for at most
    `timeout_s`. `dropped` counts the items a full queue threw away, oldest first.
    """

    def __init__(self, capacity: int = DEFAULT_CAPACITY, *, wait_when_full: bool = False) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be at least 1, got {capacity}")
        self._items: deque[Item] = deque()
        self._capacity = capacity
        self._wait_when_full = wait_when_full
        self._ready = threading.Condition(threading.Lock())
        self._closed = False
        self.put_count = 0
        self.dropped = 0

    def put(self, item: Item) -> None:
        """Queue `item`; when full, drop the oldest (counted) or, if so configured, wait."""
        with self._ready:
            while self._wait_when_full and len(self._items) >= self._capacity and not self._closed:
                self._ready.wait()
            if len(self._items) >= self._capacity:
                self._items.popleft()
                self.dropped += 1
            self._items.append(item)
            self.put_count += 1
            if len(self._items) == 1:
                self._ready.notify_all()

    def take(self, timeout_s: float) -> list[Item]:
        """Every queued item, oldest first; waits up to `timeout_s` for one (empty on timeout
        or once closed and empty)."""
        with self._ready:
            if not self._items and not self._closed:
                self._ready.wait(timeout_s)
            items = list(self._items)
            self._items.clear()
            if self._wait_when_full:
                self._ready.notify_all()
            return items

    def take_ready(self, limit: int) -> list[Item]:
        """At most `limit` queued items, oldest first, without waiting (the loop calls this)."""
        with self._ready:
            items = self._items
            if len(items) <= limit:
                taken = list(items)
                items.clear()
            else:
                taken = [items.popleft() for _ in range(limit)]
            if taken and self._wait_when_full:
                self._ready.notify_all()
            return taken

    def close(self) -> None:
        """No more items will come: wake the consumer (and a producer waiting for room)."""
        with self._ready:
            self._closed = True
            self._ready.notify_all()

    @property
    def closed(self) -> bool:
        with self._ready:
            return self._closed

    def __len__(self) -> int:
        with self._ready:
            return len(self._items)
