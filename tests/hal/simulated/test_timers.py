"""The periodic timer: absolute deadlines without drift, clean stop and restart."""

from __future__ import annotations

import pytest

from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer


def test_ticks_land_on_absolute_deadlines_without_drift() -> None:
    clock = VirtualClock()
    ticks: list[float] = []
    timer = PeriodicTimer(clock, 0.0077, ticks.append)
    timer.start(first_s=0.001)
    clock.advance(77.0)
    assert len(ticks) == 10_000
    assert ticks[-1] == pytest.approx(0.001 + 9_999 * 0.0077, abs=1e-12)
    assert timer.ticks == 10_000


def test_stop_cancels_and_restart_never_doubles_the_rate() -> None:
    clock = VirtualClock()
    ticks: list[float] = []
    timer = PeriodicTimer(clock, 0.1, ticks.append)
    timer.start()
    clock.advance(0.25)
    timer.stop()
    clock.advance(0.5)
    assert ticks == pytest.approx([0.0, 0.1, 0.2])
    timer.start()
    timer.start()  # a restart while running must not leave two series ticking
    clock.advance(0.35)
    assert ticks[3:] == pytest.approx([0.75, 0.85, 0.95, 1.05])
    assert timer.running


def test_a_period_must_be_positive() -> None:
    with pytest.raises(ValueError, match="period_s"):
        PeriodicTimer(VirtualClock(), 0.0, lambda _tick_s: None)
