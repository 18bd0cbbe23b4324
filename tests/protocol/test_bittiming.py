"""bxCAN bit timing: every row of the thesis' Figure 20, CAN_BTR fields, ip-link values, limits."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import pytest

from bywire.errors import ConfigError
from bywire.protocol import bittiming
from bywire.protocol.bittiming import BitTiming

CLOCK_HZ = 48_000_000

# Figure 20 (48 MHz, 87.5 %): kbit/s, prescaler, quanta, seg 1, seg 2, sample point %, CAN_BTR.
FIGURE_20: list[tuple[int, int, int, int, int, float, int]] = [
    (1000, 3, 16, 13, 2, 87.5, 0x001C0002),
    (1000, 4, 12, 10, 1, 91.7, 0x00090003),
    (1000, 6, 8, 6, 1, 87.5, 0x00050005),
    (800, 4, 15, 12, 2, 86.7, 0x001B0003),
    (800, 5, 12, 10, 1, 91.7, 0x00090004),
    (800, 6, 10, 8, 1, 90.0, 0x00070005),
    (500, 6, 16, 13, 2, 87.5, 0x001C0005),
    (500, 8, 12, 10, 1, 91.7, 0x00090007),
    (500, 12, 8, 6, 1, 87.5, 0x0005000B),
    (250, 12, 16, 13, 2, 87.5, 0x001C000B),
    (250, 16, 12, 10, 1, 91.7, 0x0009000F),
]
SWEEP_CLOCKS_HZ = [8, 16, 36, 42, 45, 48, 80]


@pytest.mark.parametrize("figure_row", FIGURE_20, ids=lambda row: f"{row[0]}k-brp{row[1]}")
def test_every_row_of_figure_20_is_found(
    figure_row: tuple[int, int, int, int, int, float, int],
) -> None:
    kbps, brp, tq_count, tseg1, tseg2, percent, btr = figure_row
    rows = bittiming.solutions(CLOCK_HZ, kbps * 1000)
    found = [(r.brp, r.tq_count, r.tseg1, r.tseg2, r.btr, r.bitrate_error) for r in rows]
    assert (brp, tq_count, tseg1, tseg2, btr, 0.0) in found
    row = next(r for r in rows if r.brp == brp)
    assert round(row.sample_point * 100, 1) == percent


def test_table_keeps_figure_20_order_and_marks_the_thesis_row_for_500k() -> None:
    rows = bittiming.table(CLOCK_HZ, (250_000, 500_000, 800_000, 1_000_000))
    keys = [(r.bitrate_bps, r.brp) for r in rows]
    assert keys == sorted(keys, key=lambda key: (-key[0], key[1]))
    figure_keys = [(kbps * 1000, brp) for kbps, brp, *_ in FIGURE_20]
    assert [key for key in keys if key in figure_keys] == figure_keys
    recommended = [r for r in rows if r.bitrate_bps == 500_000 and r.recommended]
    assert [(r.brp, r.tseg1, r.tseg2) for r in recommended] == [(6, 13, 2)]


def test_one_recommended_row_per_bitrate_closest_sample_point_then_most_quanta() -> None:
    for rate in bittiming.STANDARD_BITRATES_BPS:
        rows = bittiming.solutions(CLOCK_HZ, rate)
        best = [r for r in rows if r.recommended]
        assert len(best) == 1
        key = [(abs(r.sample_point - 0.875), -r.tq_count) for r in rows]
        assert rows.index(best[0]) == key.index(min(key))


def test_btr_is_built_from_the_bit_fields() -> None:
    row = BitTiming(CLOCK_HZ, 500_000, brp=6, tseg1=13, tseg2=2, sjw=3)
    assert row.btr & 0x3FF == 6 - 1
    assert row.btr >> 16 & 0xF == 13 - 1
    assert row.btr >> 20 & 0x7 == 2 - 1
    assert row.btr >> 24 & 0x3 == 3 - 1
    assert row.btr & ~0x037F03FF == 0
    assert row.btr == 0x021C0005


def test_ip_link_lines_for_the_thesis_setting() -> None:
    row = next(r for r in bittiming.solutions(CLOCK_HZ, 500_000) if r.recommended)
    assert (
        row.ip_link_bitrate("can1") == "ip link set can1 type can bitrate 500000 sample-point 0.875"
    )
    assert row.ip_link_segments() == (
        "ip link set can0 type can tq 125 prop-seg 6 phase-seg1 7 phase-seg2 2 sjw 1"
    )


def _sweep() -> list[BitTiming]:
    rates = bittiming.STANDARD_BITRATES_BPS
    clocks_hz = [mhz * 1_000_000 for mhz in SWEEP_CLOCKS_HZ]
    return [
        row
        for clock_hz, rate in itertools.product(clocks_hz, rates)
        for row in bittiming.solutions(clock_hz, rate)
    ]


def test_every_row_of_a_clock_sweep_respects_the_bxcan_limits() -> None:
    rows = _sweep()
    assert len(rows) > 100
    for row in rows:
        assert 1 <= row.brp <= 1024
        assert 1 <= row.tseg1 <= 16
        assert 1 <= row.tseg2 <= 8
        assert 1 <= row.sjw <= min(4, row.tseg2)
        assert 8 <= row.tq_count <= 25
        assert row.brp * row.tq_count * row.bitrate_bps == row.clock_hz
        assert abs(row.sample_point - 0.875) <= bittiming.SAMPLE_POINT_TOLERANCE


def test_ip_link_parameters_agree_with_the_timing() -> None:
    for row in _sweep():
        assert row.tq_ns * row.tq_count == pytest.approx(1e9 / row.bitrate_bps)
        assert row.prop_seg + row.phase_seg1 == row.tseg1
        assert row.phase_seg2 == row.tseg2
        # The kernel turns tq back into a prescaler: (clock * tq + 0.5e9 - 1) // 1e9.
        assert (row.clock_hz * row.linux_tq_ns + 499_999_999) // 1_000_000_000 == row.brp


def test_each_rate_of_a_sweep_is_sorted_by_prescaler() -> None:
    for mhz, rate in itertools.product(SWEEP_CLOCKS_HZ, bittiming.STANDARD_BITRATES_BPS):
        prescalers = [r.brp for r in bittiming.solutions(mhz * 1_000_000, rate)]
        assert prescalers == sorted(prescalers)


def test_sjw_above_tseg2_drops_the_row() -> None:
    rows = bittiming.solutions(CLOCK_HZ, 500_000, sjw=2)
    assert [(r.brp, r.sjw) for r in rows] == [(6, 2)]
    assert rows[0].btr == 0x011C0005


def test_sample_point_rounds_half_up() -> None:
    rows = {r.tq_count: r for r in bittiming.solutions(CLOCK_HZ, 500_000, 0.75)}
    assert (rows[16].tseg1, rows[16].tseg2) == (11, 4)
    assert (rows[12].tseg1, rows[12].tseg2) == (8, 3)


def test_no_exact_setting_gives_an_empty_list_and_a_nearest_suggestion() -> None:
    assert bittiming.solutions(45_000_000, 800_000) == []
    suggestion = bittiming.nearest(45_000_000, 800_000)
    assert suggestion is not None
    assert 0.0 < abs(suggestion.bitrate_error) < 0.01
    assert suggestion.actual_bitrate_bps == pytest.approx(
        45e6 / (suggestion.brp * suggestion.tq_count)
    )


def test_nearest_returns_the_exact_row_when_there_is_one() -> None:
    suggestion = bittiming.nearest(CLOCK_HZ, 500_000)
    assert suggestion is not None
    assert (suggestion.brp, suggestion.bitrate_error) == (6, 0.0)


def test_bitrate_range_follows_the_prescaler_and_quanta_limits() -> None:
    assert bittiming.bitrate_range_bps(CLOCK_HZ) == range(1875, 6_000_001)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: bittiming.solutions(0, 500_000), "clock"),
        (lambda: bittiming.solutions(-48_000_000, 500_000), "clock"),
        (lambda: bittiming.solutions(CLOCK_HZ, 0), r"1875\.\.6000000 bit/s"),
        (lambda: bittiming.solutions(CLOCK_HZ, 7_000_000), r"1875\.\.6000000 bit/s"),
        (lambda: bittiming.solutions(CLOCK_HZ, 1000), r"1875\.\.6000000 bit/s"),
        (lambda: bittiming.solutions(CLOCK_HZ, 500_000, 0.49), r"0\.5\.\.0\.95"),
        (lambda: bittiming.solutions(CLOCK_HZ, 500_000, 0.96), r"0\.5\.\.0\.95"),
        (lambda: bittiming.solutions(CLOCK_HZ, 500_000, math.nan), r"0\.5\.\.0\.95"),
        (lambda: bittiming.solutions(CLOCK_HZ, 500_000, sjw=0), r"1\.\.4"),
        (lambda: bittiming.solutions(CLOCK_HZ, 500_000, sjw=5), r"1\.\.4"),
        (lambda: bittiming.nearest(CLOCK_HZ, 500_000, sjw=5), r"1\.\.4"),
    ],
)
def test_bad_inputs_name_the_allowed_range(call: Callable[[], object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        call()
