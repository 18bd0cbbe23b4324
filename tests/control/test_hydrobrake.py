"""Hydraulic brake duty against Figure 13 of the thesis."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.hydrobrake import hydrobrake_duty


@pytest.mark.parametrize(
    ("brake_norm", "threshold_norm", "expected_duty"),
    [
        (0.0, 0.5, 0.0),
        (0.3, 0.5, 0.0),
        (0.5, 0.5, 0.0),  # Figure 13 uses a strict ">": at the threshold the duty is still zero
        (0.75, 0.5, 0.5),
        (1.0, 0.5, 1.0),
        (0.6, 0.2, 0.5),
        (0.0, 0.0, 0.0),
        (0.4, 0.0, 0.4),
        (1.5, 0.5, 1.0),
        (-0.2, 0.5, 0.0),
        (math.nan, 0.5, 1.0),
    ],
)
def test_duty_follows_figure_13(
    brake_norm: float, threshold_norm: float, expected_duty: float
) -> None:
    assert hydrobrake_duty(brake_norm, threshold_norm) == pytest.approx(expected_duty)


@given(
    st.floats(0.0, 1.0),
    st.floats(0.0, 1.0),
    st.floats(0.0, 0.99),
)
def test_duty_is_monotonic_and_bounded(first: float, second: float, threshold: float) -> None:
    low, high = sorted((first, second))
    low_duty, high_duty = hydrobrake_duty(low, threshold), hydrobrake_duty(high, threshold)
    assert 0.0 <= low_duty <= high_duty <= 1.0


@pytest.mark.parametrize("threshold_norm", [-0.1, 1.0, 1.5, math.nan])
def test_threshold_outside_its_range_is_refused(threshold_norm: float) -> None:
    with pytest.raises(ValueError, match="threshold"):
        hydrobrake_duty(0.5, threshold_norm)
