"""The simulator's clocks: timers in order, jumps without sleeping, input wakes the waiter."""

from __future__ import annotations

import time

import pytest

from bywire.hal.simulated.clock import RealtimeClock, ScaledRealtimeClock, VirtualClock


def test_wait_jumps_to_the_deadline_when_no_timer_is_due() -> None:
    clock = VirtualClock()
    clock.wait_until(3600.0)
    assert clock.now() == 3600.0


def test_timers_run_in_time_order_and_equal_times_in_setting_order() -> None:
    clock = VirtualClock()
    seen: list[tuple[str, float]] = []
    clock.call_at(0.2, lambda: seen.append(("late", clock.now())))
    clock.call_at(0.1, lambda: seen.append(("first", clock.now())))
    clock.call_at(0.1, lambda: seen.append(("second", clock.now())))
    clock.wait_until(1.0)
    assert seen == [("first", 0.1), ("second", 0.1), ("late", 0.2)]
    assert clock.now() == 1.0


def test_input_from_a_timer_wakes_the_waiter_at_that_instant() -> None:
    clock = VirtualClock()
    clock.call_at(0.0123, clock.notify_input)
    clock.call_at(0.5, lambda: None)
    clock.wait_until(0.01)
    assert clock.now() == 0.01
    clock.wait_until(0.02)
    assert clock.now() == 0.0123


def test_input_that_arrived_before_the_wait_returns_at_once() -> None:
    clock = VirtualClock(start_s=5.0)
    clock.notify_input()
    clock.wait_until(6.0)
    assert clock.now() == 5.0
    clock.wait_until(6.0)
    assert clock.now() == 6.0


def test_timers_set_from_timers_run_in_the_same_wait() -> None:
    clock = VirtualClock()
    ticks: list[float] = []

    def tick() -> None:
        ticks.append(clock.now())
        clock.call_at(clock.now() + 0.25, tick)

    clock.call_at(0.0, tick)
    clock.advance(1.0)
    assert ticks == [0.0, 0.25, 0.5, 0.75, 1.0]


def test_virtual_time_never_sleeps(monkeypatch: pytest.MonkeyPatch) -> None:
    def forbidden(_seconds: float) -> None:
        raise AssertionError("the virtual clock slept")

    monkeypatch.setattr(time, "sleep", forbidden)
    clock = VirtualClock()
    clock.call_at(1800.0, lambda: None)
    clock.advance(3600.0)
    assert clock.now() == 3600.0


def test_realtime_clock_runs_timers_no_earlier_than_their_time() -> None:
    clock = RealtimeClock()
    fired_at: list[float] = []
    due_s = clock.now() + 0.02
    clock.call_at(due_s, lambda: fired_at.append(clock.now()))
    clock.wait_until(due_s + 0.01)
    assert len(fired_at) == 1
    assert fired_at[0] >= due_s
    assert clock.now() >= due_s + 0.01


def test_a_scaled_realtime_clock_runs_n_times_faster_than_the_wall_clock() -> None:
    """`bywire sim --speed 10`: a timer 0.5 simulated seconds ahead fires after ~0.05 s of wall
    time, never before it."""
    clock = ScaledRealtimeClock(speed=10.0)
    fired: list[float] = []
    clock.call_at(0.5, lambda: fired.append(clock.now()))
    started = time.monotonic()
    clock.wait_until(0.6)
    wall_s = time.monotonic() - started
    assert fired
    assert fired[0] >= 0.5
    assert clock.now() >= 0.6
    assert 0.06 <= wall_s < 0.6  # a tenth of the simulated time; real time would be 0.6 s


def test_input_during_a_hung_write_wakes_the_next_wait_at_once() -> None:
    # Issue 41: a frame that arrived while a slow DAC transfer let virtual time run was taken
    # by the transfer's own wait, and the loop slept on to its next tick (up to a control
    # period more). On the robot the interrupt's wake-up event stays set until the next wait.
    clock = VirtualClock()
    clock.call_at(0.002, clock.notify_input)
    clock.advance(0.005)  # the hung write: timers run, the input stays pending
    assert clock.now() == 0.005
    clock.wait_until(0.010)
    assert clock.now() == 0.005
    clock.wait_until(0.010)  # consumed once
    assert clock.now() == 0.010
