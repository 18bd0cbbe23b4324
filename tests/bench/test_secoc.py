"""The SecOC cost measurement: both readers take every command; the cost figure has its goal."""

from __future__ import annotations

import subprocess
import sys

import pytest

from bywire.bench.figures import SECOC_COST_LIMIT_MS, secoc_figures
from bywire.bench.secoc import measure_secoc_cost


def test_both_readers_accept_every_command_and_the_wire_time_is_one_8_byte_frame() -> None:
    cost = measure_secoc_cost(samples=300, bitrate_bps=500_000)
    assert (cost.plain.samples, cost.authenticated.samples) == (300, 300)
    assert cost.wire_s == pytest.approx(135 / 500_000)
    assert cost.authenticated.p99_s is not None
    assert cost.plain.p99_s is not None
    assert cost.p99_cost_s == pytest.approx(cost.authenticated.p99_s - cost.plain.p99_s)


def test_the_cost_figure_has_the_issue_s_goal() -> None:
    figures = {figure.key: figure for figure in secoc_figures(measure_secoc_cost(samples=50))}
    cost = figures["secoc_cost_p99_ms"]
    assert (cost.limit, cost.unit, cost.target) == (SECOC_COST_LIMIT_MS, "ms", "≤ 0.05 ms")
    assert figures["secoc_wire_ms"].value == pytest.approx(0.27)


def test_the_bench_loads_cryptography_only_to_measure_secoc() -> None:
    """The real-time session's peak memory is the controller's: with `lock_memory`, an unused
    11 MB native library mapped by the bench's own key would count as the controller's."""
    probe = "import sys, bywire.cli.bench\nprint('cryptography' in sys.modules)\n"
    loaded = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True
    ).stdout.split()
    assert loaded == ["False"]
