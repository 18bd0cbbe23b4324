"""Order statistics for the benchmark: nearest-rank percentiles and latency summaries.

p99.9 of n values is the ceil(0.999 n)-th smallest: with fewer than 1000 values that is the
maximum itself, so the figures say how many samples they rest on (`tail_note`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

_RANK_SLACK = 1e-9  # so that 0.99 * 1500 (= 1485.0000000000002 in floats) ranks as 1485


def percentile(values: Sequence[float], fraction: float) -> float:
    """Nearest-rank percentile: the smallest value with at least ``fraction`` of all values ≤ it.

    ``fraction`` is 0 < fraction ≤ 1 (0.99 for p99). ValueError for no values.
    """
    if not values:
        raise ValueError("percentile of no values")
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    ordered = sorted(values)
    rank = max(math.ceil(fraction * len(ordered) - _RANK_SLACK), 1)
    return ordered[rank - 1]


TAIL_SAMPLES = 1000
"""Fewest samples for which p99.9 is not simply the maximum: below this, say so."""


@dataclass(frozen=True, slots=True)
class LatencySummary:
    """p50, p99, p99.9 and max of a set of latencies (None when there were none) and the counts."""

    samples: int
    unpaired: int
    p50_s: float | None
    p99_s: float | None
    p999_s: float | None
    max_s: float | None


def summarise(latencies_s: Sequence[float], unpaired: int = 0) -> LatencySummary:
    """The summary of ``latencies_s``; ``unpaired`` counts commands whose write was not found."""
    if not latencies_s:
        return LatencySummary(0, unpaired, None, None, None, None)
    return LatencySummary(
        samples=len(latencies_s),
        unpaired=unpaired,
        p50_s=percentile(latencies_s, 0.50),
        p99_s=percentile(latencies_s, 0.99),
        p999_s=percentile(latencies_s, 0.999),
        max_s=max(latencies_s),
    )


def tail_note(samples: int) -> str:
    """What a p99.9 from ``samples`` values is worth, for the table's note."""
    if samples >= TAIL_SAMPLES:
        return f"n={samples}"
    return f"n={samples} < {TAIL_SAMPLES}: p99.9 is the max"
