"""A run's samples in bounded memory: when full, every second one goes and the spacing doubles.

A run of any length keeps at most `capacity` samples, evenly spaced over the whole run (a plot of
an hour shows the hour, at a coarser step), so a long `bywire sim --realtime` stays flat in
memory after its first `capacity` samples. The newest sample offered is always at hand (`last`),
kept or not: the summary's distance and the progress bar read it.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Generic, TypeVar

T = TypeVar("T")

DEFAULT_CAPACITY = 6000  # a minute of samples at the plot's 10 ms


class Trace(Generic[T]):
    """Samples offered in time order; keeps one in `stride` of them, at most `capacity`."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 2:
            raise ValueError(f"a trace holds at least 2 samples, not {capacity}")
        self.capacity = capacity
        self.stride = 1
        """One sample kept in this many offered (doubles at each thinning)."""
        self.offered = 0
        self.last: T | None = None
        self._kept: list[T] = []

    def append(self, sample: T) -> None:
        """Offer the next sample: kept if it falls on the stride; the oldest are thinned first."""
        self.last = sample
        index = self.offered
        self.offered += 1
        if index % self.stride:
            return
        if len(self._kept) == self.capacity:
            # Kept samples are offered indexes 0, s, 2s, ...: keeping every second one leaves
            # 0, 2s, 4s, ..., so the new stride 2s holds for what comes next.
            del self._kept[1::2]
            self.stride *= 2
            if index % self.stride:
                return
        self._kept.append(sample)

    def __len__(self) -> int:
        return len(self._kept)

    def __iter__(self) -> Iterator[T]:
        return iter(self._kept)

    def __getitem__(self, index: int) -> T:
        return self._kept[index]

    def __bool__(self) -> bool:
        return bool(self._kept)
