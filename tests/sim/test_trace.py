"""A run's samples in bounded memory: at most `capacity`, evenly spaced over the whole run."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.sim.trace import Trace


def test_a_short_run_keeps_every_sample() -> None:
    trace: Trace[int] = Trace(capacity=10)
    for sample in range(10):
        trace.append(sample)
    assert list(trace) == list(range(10))
    assert trace.last == 9


@given(capacity=st.integers(2, 50), offered=st.integers(0, 2000))
def test_a_long_run_keeps_at_most_capacity_evenly_spaced_from_the_first(
    capacity: int, offered: int
) -> None:
    trace: Trace[int] = Trace(capacity)
    for sample in range(offered):
        trace.append(sample)
    kept = list(trace)
    assert len(kept) <= capacity
    assert kept == list(range(0, offered, trace.stride))  # the first, then one every stride
    assert trace.last == (offered - 1 if offered else None)
    if offered > capacity:
        assert len(kept) > capacity // 2  # thinned by half at most: the plot keeps its detail


def test_a_capacity_below_two_is_refused() -> None:
    with pytest.raises(ValueError, match="at least 2"):
        Trace(1)
