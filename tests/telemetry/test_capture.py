"""The loop's tap: the state at its rate on absolute deadlines, events as they happen."""

from __future__ import annotations

import marshal

import pytest

from bywire.config import default_sim_config
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from bywire.telemetry.capture import Capture, EventCapture, StateCapture, TelemetryTap
from bywire.telemetry.outbox import Outbox


def _course(duration_s: float) -> SimRun:
    return SimRun(default_sim_config(), find_scenario("test-course"), duration_s=duration_s)


def _tapped(
    duration_s: float, capacity: int = 100_000, rate_hz: float = 50.0
) -> tuple[SimRun, Outbox[Capture]]:
    sim = _course(duration_s)
    outbox: Outbox[Capture] = Outbox(capacity)
    TelemetryTap(sim.runtime, outbox, rate_hz=rate_hz).attach()
    sim.run()
    return sim, outbox


@pytest.mark.parametrize("rate_hz", [50.0, 20.0, 10.0])
def test_the_state_comes_at_the_configured_rate_on_absolute_deadlines(rate_hz: float) -> None:
    _sim, outbox = _tapped(2.0, rate_hz=rate_hz)
    times = [c.time_s for c in outbox.take(0.0) if isinstance(c, StateCapture)]
    assert times == pytest.approx([k / rate_hz for k in range(round(2.0 * rate_hz))], abs=1e-9)


def test_every_mode_change_is_an_event_at_the_instant_of_the_decision() -> None:
    sim, outbox = _tapped(40.0)
    events = [c for c in outbox.take(0.0) if isinstance(c, EventCapture)]
    modes = [(e.time_s, e.name) for e in events if e.kind == "mode"]
    assert modes == [(time_s, mode.name) for time_s, mode in sim.runtime.mode_log]
    assert [name for _, name in modes] == ["STOP", "RC", "CAN", "RC", "STOP"]


def test_latches_and_flags_are_events_when_they_come_and_when_they_clear() -> None:
    """The course starts latched (power-up, no RC yet) and arms within its first second."""
    _sim, outbox = _tapped(1.5)
    events = [(e.kind, e.name) for e in outbox.take(0.0) if isinstance(e, EventCapture)]
    assert ("latched", "POWER_UP") in events
    assert ("flag_raised", "NOT_ARMED") in events
    assert events.index(("cleared", "POWER_UP")) > events.index(("latched", "POWER_UP"))
    assert events.index(("flag_cleared", "NOT_ARMED")) > events.index(("flag_raised", "NOT_ARMED"))


def test_a_state_capture_holds_plain_values_and_copies_of_the_counters() -> None:
    sim, outbox = _tapped(3.0)
    captures = outbox.take(0.0)
    last = [c for c in captures if isinstance(c, StateCapture)][-1]
    assert last.mode == sim.runtime.mode_log[-1][1].name
    assert [row[0] for row in last.tasks] == [task.spec.name for task in sim.runtime.tasks]
    # The loop ran on after the capture: the copies kept the counts of their instant.
    steering = sim.runtime.tasks[0]
    assert 0 < last.tasks[0][2] < steering.stats.runs
    # Plain values only: what `marshal` (the pipe to the writer's process) can carry.
    for capture in captures:
        assert marshal.loads(marshal.dumps(tuple(capture))) == tuple(capture)


def test_a_stuck_consumer_loses_the_oldest_captures_never_the_loops_passes() -> None:
    """Nobody takes from a small outbox: the run still ends with every task run as without a
    tap, and the outbox holds the newest captures, the rest counted as dropped."""
    plain = _course(3.0)
    plain.run()
    sim, outbox = _tapped(3.0, capacity=16)
    runs = [task.stats.runs for task in sim.runtime.tasks]
    assert runs == [task.stats.runs for task in plain.runtime.tasks]
    kept = outbox.take(0.0)
    assert len(kept) == 16
    assert outbox.dropped == outbox.put_count - 16 > 0
    states = [c for c in kept if isinstance(c, StateCapture)]
    assert states[-1].time_s == pytest.approx(2.98)
    assert states[-1].telemetry_dropped > 0


def test_the_rate_must_be_positive() -> None:
    with pytest.raises(ValueError, match="rate"):
        TelemetryTap(_course(1.0).runtime, Outbox(4), rate_hz=0.0)
