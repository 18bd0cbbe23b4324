"""Input validity, one definition: the multiplexer, the safety checks and the error report use it.

An input is usable only if it has been seen (invalid until first seen), passed its checks when it
arrived (the codecs reject bad frames as a whole, so a slot only ever holds a complete value), and
is not older than its timeout at the instant of the decision.
"""

from __future__ import annotations

from typing import Generic, TypeVar

from bywire.control.values import value

T = TypeVar("T")


@value
class Stamped(Generic[T]):
    """A value with the clock time at which it arrived."""

    value: T
    received_at: float


def is_fresh(slot: Stamped[T] | None, now: float, timeout_s: float) -> bool:
    """Seen, and at most `timeout_s` old at `now`.

    A value stamped in the future (clock stepped back) counts as stale: never trust what cannot be.
    """
    return slot is not None and 0.0 <= now - slot.received_at <= timeout_s


def fresh(slot: Stamped[T] | None, now: float, timeout_s: float) -> T | None:
    """The slot's value if it is fresh (see `is_fresh`), else None."""
    return slot.value if slot is not None and is_fresh(slot, now, timeout_s) else None


def age_s(slot: Stamped[T] | None, now: float) -> float | None:
    """How old the slot is at `now`; None if never seen."""
    return None if slot is None else now - slot.received_at
