"""The watchdog: trips once on a stalled loop, only then, from its own thread too."""

from __future__ import annotations

import threading
from collections.abc import Callable

import pytest

from bywire.runtime.watchdog import NOTIFY_PERIOD_S, POLL_S, Watchdog


class FakeTime:
    """A monotonic clock the test moves by hand."""

    def __init__(self, now_s: float = 100.0) -> None:
        self.now_s = now_s

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


# Tests added after mutation testing (docs/mutation.md). The watchdog thread's body on virtual
# time (its stop event replaced by one that advances a fake clock), and its thread's life: named,
# a daemon, joined on stop, stop safe to repeat.


class VirtualStop(threading.Event):
    """Stands in for the watchdog's stop event: each wait moves the fake clock instead of
    sleeping, lets the loop feed, and asks the watchdog to stop after `polls` waits."""

    def __init__(self, clock: FakeTime, polls: int, on_poll: Callable[[float], None]) -> None:
        super().__init__()
        self.clock, self.polls, self.on_poll = clock, polls, on_poll
        self.timeouts: list[float] = []

    def wait(self, timeout: float | None = None) -> bool:
        assert timeout is not None  # the watchdog always polls with a timeout
        if len(self.timeouts) == self.polls:
            return True
        self.timeouts.append(timeout)
        self.on_poll(timeout)
        return False


def watch(
    limit_s: float, polls: int, step: Callable[[FakeTime, Watchdog, float], None]
) -> tuple[Watchdog, VirtualStop, list[str]]:
    """Run the watchdog's thread body for `polls` polls in this thread; `step` plays the time
    and the loop's feeding at each poll."""
    clock, notes = FakeTime(1.0), list[str]()
    watchdog = Watchdog(lambda: None, limit_s, monotonic=clock, notify=notes.append)
    stop = VirtualStop(clock, polls, lambda timeout: step(clock, watchdog, timeout))
    watchdog._stop = stop
    watchdog._watch()
    return watchdog, stop, notes


def healthy_loop(clock: FakeTime, watchdog: Watchdog, timeout: float) -> None:
    clock.now_s += timeout
    watchdog.feed()


def test_a_short_limit_is_polled_four_times_per_limit() -> None:
    limit_s = 2.0**-6  # 15.6 ms, shorter than four polls of POLL_S
    assert limit_s / 4 < POLL_S
    _, stop, _ = watch(limit_s, 8, healthy_loop)
    assert stop.timeouts == [limit_s / 4] * 8


def test_a_long_limit_is_polled_every_poll_period() -> None:
    _, stop, _ = watch(0.2, 8, healthy_loop)
    assert stop.timeouts == [POLL_S] * 8


def test_a_healthy_loop_notifies_systemd_once_per_notify_period() -> None:
    one_second = round(1.0 / POLL_S)
    watchdog, _, notes = watch(0.2, one_second, healthy_loop)
    assert not watchdog.tripped
    assert set(notes) == {"WATCHDOG=1"}
    assert round(1.0 / NOTIFY_PERIOD_S) <= len(notes) <= round(1.0 / NOTIFY_PERIOD_S) + 1


def test_notifications_are_due_from_exactly_one_notify_period_after_the_last() -> None:
    times = iter([1.0, 1.0 + NOTIFY_PERIOD_S])

    def scripted(clock: FakeTime, watchdog: Watchdog, _timeout: float) -> None:
        clock.now_s = next(times)
        watchdog.feed()

    _, _, notes = watch(0.2, 2, scripted)
    assert notes == ["WATCHDOG=1", "WATCHDOG=1"]


def test_a_stalled_loop_trips_and_sends_no_more_notifications() -> None:
    def stalled(clock: FakeTime, _watchdog: Watchdog, timeout: float) -> None:
        clock.now_s += timeout

    watchdog, _, notes = watch(0.2, 100, stalled)
    assert watchdog.tripped
    assert watchdog.trips == 1
    # one at the first poll and one a notify period later; none once the 0.2 s limit is past
    assert len(notes) == 2


def test_tripped_is_a_plain_false_before_a_trip_and_after_reset() -> None:
    clock = FakeTime(1.0)
    watchdog = Watchdog(lambda: None, 0.2, monotonic=clock)
    assert watchdog.tripped is False
    clock.now_s += 1.0
    assert watchdog.check() is True
    watchdog.reset()
    assert watchdog.tripped is False


def _watchdog_threads() -> list[threading.Thread]:
    return [thread for thread in threading.enumerate() if thread.name == "bywire-watchdog"]


def test_the_thread_is_a_named_daemon_and_is_gone_after_stop() -> None:
    watchdog = Watchdog(lambda: None, 60.0)
    assert _watchdog_threads() == []
    watchdog.start()
    try:
        (thread,) = _watchdog_threads()
        assert thread.daemon  # a loop that dies without stop() must not keep the process alive
    finally:
        watchdog.stop()
    assert not thread.is_alive()
    assert _watchdog_threads() == []


@pytest.mark.parametrize("starts", [0, 1])
def test_stop_is_safe_before_start_and_when_repeated(starts: int) -> None:
    watchdog = Watchdog(lambda: None, 60.0)
    for _ in range(starts):
        watchdog.start()
    watchdog.stop()
    watchdog.stop()
    assert _watchdog_threads() == []


def test_a_trip_whose_safe_writes_check_it_again_does_not_deadlock() -> None:
    # In the simulator a trip's safe DAC write, crawling, runs the virtual clock, whose timers
    # check the watchdog again on the same thread (`bywire verify --draw-robots` hung there).
    clock, seen = FakeTime(), []
    watchdog: Watchdog

    def on_trip() -> None:
        seen.append(watchdog.check())  # the clock's timer, inside the trip's safe write

    watchdog = Watchdog(on_trip, 0.2, monotonic=clock)
    clock.now_s += 0.3
    checking = threading.Thread(target=watchdog.check, daemon=True)
    checking.start()
    checking.join(timeout=5.0)
    assert not checking.is_alive()
    assert seen == [True]  # the inner check finds it tripped, and it tripped once
    assert watchdog.trips == 1
