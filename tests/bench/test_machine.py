"""`bywire.bench.machine`: the machine's stolen CPU time and CPU pressure, read from /proc."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bywire.bench.machine import cpu_pressure_s, steal_s


def test_steal_is_the_eighth_field_of_the_cpu_line_in_clock_ticks(tmp_path: Path) -> None:
    stat = tmp_path / "stat"
    stat.write_text(
        "cpu  1400702 0 23764 650267 2589 0 1549 33665 0 0\ncpu0 1 2 3 4 5 6 7 8 0 0\n",
        encoding="ascii",
    )
    assert steal_s(stat) == pytest.approx(33665 / os.sysconf("SC_CLK_TCK"))
    assert steal_s(tmp_path / "missing") == 0.0


def test_cpu_pressure_is_the_some_total_in_microseconds(tmp_path: Path) -> None:
    pressure = tmp_path / "cpu"
    pressure.write_text(
        "some avg10=53.68 avg60=47.20 avg300=24.40 total=3180062269\n"
        "full avg10=0.00 avg60=0.00 avg300=0.00 total=0\n",
        encoding="ascii",
    )
    assert cpu_pressure_s(pressure) == pytest.approx(3180.062269)
    assert cpu_pressure_s(tmp_path / "missing") == 0.0


def test_this_machine_counts_both_without_error() -> None:
    assert steal_s() >= 0.0
    assert cpu_pressure_s() >= 0.0
