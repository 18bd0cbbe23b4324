"""`bywire.bench.stats`: p99.9 beside p50 and p99, and what a p99.9 from few samples is worth."""

from __future__ import annotations

import pytest

from bywire.bench.stats import TAIL_SAMPLES, percentile, summarise, tail_note


def test_p999_of_two_thousand_values_is_the_third_largest_not_the_max() -> None:
    values = [0.001 * v for v in reversed(range(1, 2001))]
    summary = summarise(values)
    assert summary.samples == 2000
    assert summary.p99_s == pytest.approx(1.980)
    assert summary.p999_s == pytest.approx(1.998)  # rank ceil(0.999 * 2000) = 1998
    assert summary.max_s == pytest.approx(2.000)


def test_p999_sees_one_outlier_in_a_thousand_only_when_there_are_two() -> None:
    one = [0.0001] * 999 + [0.005]
    two = [0.0001] * 998 + [0.005, 0.006]
    assert summarise(one).p999_s == pytest.approx(0.0001)  # the 999th of 1000
    assert summarise(two).p999_s == pytest.approx(0.005)


def test_with_fewer_than_a_thousand_samples_p999_is_the_max() -> None:
    values = [float(v) for v in range(1, 500)]
    assert percentile(values, 0.999) == max(values)


def test_no_latencies_have_no_p999() -> None:
    assert summarise([], unpaired=1).p999_s is None


@pytest.mark.parametrize(
    ("samples", "warned"), [(0, True), (999, True), (TAIL_SAMPLES, False), (18_000, False)]
)
def test_the_note_says_when_p999_rests_on_too_few_samples(samples: int, warned: bool) -> None:
    note = tail_note(samples)
    assert f"n={samples}" in note
    assert ("p99.9 is the max" in note) is warned
