"""`bywire.bench.tail`: a late interval split into its causes, from the thread's counters.

The arithmetic is checked on hand-made timelines, where every part is known; the probe itself
runs on the real clock and is checked for what it records, never for how long anything took.
"""

from __future__ import annotations

import gc

import pytest

from bywire.bench.tail import (
    ASLEEP,
    CONTROLLER,
    PARTS,
    SIMULATOR,
    ProbedClock,
    Timeline,
    explain_tail,
    gc_figures,
)

MS = 0.001


def _timeline() -> Timeline:
    """1 ms of controller pass (0.8 CPU, 0.1 queued, a 0.3 ms gen-1 collection inside), 1 ms of
    simulator (0.4 CPU), 3 ms asleep (1 ms of it queued after the timer fired), then a pass."""
    timeline = Timeline()
    for time_ms, cpu_ms, queued_ms, state in [
        (0.0, 0.0, 0.0, CONTROLLER),
        (1.0, 0.8, 0.1, SIMULATOR),
        (2.0, 1.2, 0.1, ASLEEP),
        (5.0, 1.2, 1.1, CONTROLLER),
        (6.0, 2.2, 1.1, SIMULATOR),
    ]:
        timeline.add(time_ms * MS, cpu_ms * MS, queued_ms * MS, state)
    timeline.gc_starts_s.append(0.2 * MS)
    timeline.gc_ends_s.append(0.5 * MS)
    timeline.gc_generations.append(1)
    return timeline


def test_an_interval_is_split_into_parts_that_add_up_to_its_length() -> None:
    parts = _timeline().explain(0.0, 5 * MS)
    expected = {
        "gc": 0.3,
        "runqueue": 1.1,
        "wake": 2.0,
        "blocked": 0.7,
        "controller": 0.5,
        "simulator": 0.4,
    }
    assert parts == pytest.approx({name: ms * MS for name, ms in expected.items()})
    assert sum(parts.values()) == pytest.approx(5 * MS)


def test_a_segment_cut_by_the_interval_counts_in_proportion() -> None:
    parts = _timeline().explain(0.5 * MS, 1.5 * MS)
    assert parts["gc"] == 0.0  # the collection ended at 0.5 ms
    assert parts["controller"] == pytest.approx(0.4 * MS)
    assert parts["simulator"] == pytest.approx(0.2 * MS)
    assert parts["blocked"] == pytest.approx(0.05 * MS + 0.3 * MS)
    assert sum(parts.values()) == pytest.approx(1 * MS)


def test_the_tail_counts_only_intervals_over_the_threshold_and_names_their_main_cause() -> None:
    timeline = _timeline()
    intervals = [(0.0, 0.1 * MS), (2.0 * MS, 5.0 * MS), (0.0, 1.0 * MS)]
    tail = explain_tail(timeline, "can", intervals, threshold_s=0.5 * MS)
    assert (tail.samples, tail.late) == (3, 2)
    assert tail.dominant["wake"] == 1  # 2-5 ms: asleep past the timer
    assert tail.dominant["controller"] == 1  # 0-1 ms: the pass's own CPU
    assert set(tail.parts_s) == set(PARTS)
    length_s, start_s, _parts = tail.worst[0]
    assert length_s == pytest.approx(3 * MS)
    assert start_s == 2.0 * MS


def test_collections_are_counted_per_generation_in_their_span() -> None:
    figures = {f.generation: f for f in gc_figures(_timeline(), (0.0, 1.0))}
    assert figures[1].count == 1
    assert figures[1].max_s == pytest.approx(0.3 * MS)
    assert figures[0].count == figures[2].count == 0
    assert gc_figures(_timeline(), (1.0, 2.0))[1].count == 0


def test_late_wakes_are_those_after_their_deadline() -> None:
    timeline = Timeline()
    for deadline, woke in [(1.0, 1.0002), (2.0, 1.5), (3.0, 3.001)]:
        timeline.wake_deadlines_s.append(deadline)
        timeline.wakes_s.append(woke)
    assert timeline.late_wakes((0.0, 2.5)) == [(1.0, 1.0002)]
    assert len(timeline.late_wakes((0.0, 10.0))) == 2


def test_the_probe_records_waits_sleeps_wake_ups_and_collections() -> None:
    clock = ProbedClock()
    clock.start()
    try:
        deadline_s = clock.now() + 0.005

        def collect_oldest() -> None:
            gc.collect(2)

        clock.call_at(clock.now() + 0.001, collect_oldest)
        clock.wait_until(deadline_s)
    finally:
        clock.stop()
    timeline = clock.timeline
    states = list(timeline.states)
    assert states[:3] == [CONTROLLER, SIMULATOR, ASLEEP]
    assert states[-1] == CONTROLLER
    assert list(timeline.times_s) == sorted(timeline.times_s)
    assert list(timeline.cpu_s) == sorted(timeline.cpu_s)
    assert list(timeline.wake_deadlines_s) == [deadline_s]
    assert 2 in timeline.gc_generations
    assert all(getattr(callback, "__self__", None) is not clock for callback in gc.callbacks)
    samples = len(timeline.times_s)
    clock.wait_until(clock.now())
    assert len(timeline.times_s) == samples  # stopped: nothing more is recorded
