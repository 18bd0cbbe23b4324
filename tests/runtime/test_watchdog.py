"""The watchdog: trips once on a stalled loop, only then, from its own thread too."""

from __future__ import annotations

import threading

import pytest

from bywire.runtime.watchdog import Watchdog


class FakeTime:
    """A monotonic clock the test moves by hand."""

    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_trips_once_after_the_limit_and_not_before() -> None:
    clock, trips = FakeTime(), []
    watchdog = Watchdog(lambda: trips.append(clock.now_s), 0.25, monotonic=clock)
    clock.now_s += 0.25  # exact in binary: the boundary itself is tested
    assert not watchdog.check()  # exactly at the limit: not yet
    clock.now_s += 0.0001
    assert watchdog.check()
    clock.now_s += 5.0
    assert watchdog.check()
    assert trips == [pytest.approx(100.2501)]
    assert watchdog.trips == 1


def test_feeding_keeps_it_quiet() -> None:
    clock, trips = FakeTime(), []
    watchdog = Watchdog(lambda: trips.append(1), 0.2, monotonic=clock)
    for _ in range(100):
        clock.now_s += 0.15
        watchdog.feed()
        assert not watchdog.check()
    assert trips == []


def test_reset_rearms_it() -> None:
    clock = FakeTime()
    watchdog = Watchdog(lambda: None, 0.2, monotonic=clock)
    clock.now_s += 1.0
    assert watchdog.check()
    watchdog.reset()
    assert not watchdog.tripped
    clock.now_s += 0.1
    assert not watchdog.check()
    clock.now_s += 0.2
    assert watchdog.check()
    assert watchdog.trips == 2


def test_the_thread_trips_on_a_loop_that_never_feeds_and_notifies_while_healthy() -> None:
    tripped = threading.Event()
    notes: list[str] = []
    watchdog = Watchdog(tripped.set, 0.05, notify=notes.append)
    watchdog.start()
    try:
        assert tripped.wait(timeout=10.0)
    finally:
        watchdog.stop()
    assert watchdog.tripped
    assert set(notes) <= {"WATCHDOG=1"}


def test_a_zero_limit_is_refused() -> None:
    with pytest.raises(ValueError, match="limit"):
        Watchdog(lambda: None, 0.0)
