"""A kind of fault that happened recently: the flag stays up for a while after the last one."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from bywire.error_flags import ErrorFlag

FAULT_HOLD_S = 0.5  # a flag stays up this long after the last bad frame, so a report catches it


@dataclass(slots=True)
class RecentFault:
    """When a kind of fault last happened, and how often."""

    count: int = 0
    last_at: float | None = None

    def happened(self, now: float, times: int = 1) -> None:
        self.count += times
        self.last_at = now

    def active(self, now: float) -> bool:
        return self.last_at is not None and now - self.last_at <= FAULT_HOLD_S


def active_flags(sources: Iterable[tuple[RecentFault, ErrorFlag]], now: float) -> int:
    """The flags of every source whose fault happened recently (as an int: the decision's type)."""
    flags = 0
    for fault, flag in sources:
        if fault.active(now):
            flags |= int(flag)
    return flags
