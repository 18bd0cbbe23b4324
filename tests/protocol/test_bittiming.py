"""bxCAN bit timing: Figure 20, CAN_BTR fields, ip-link values, limits; checked on a grid against
a port of Linux's can_calc_bittiming()/can_fixup_bittiming() and against python-can's BitTiming."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import can
import pytest

from bywire.errors import ConfigError, FrameError
from bywire.protocol import bittiming
from bywire.protocol.bittiming import BitTiming
from tests.protocol import linux_bittiming as linux

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
        row.ip_link_bitrate("can1")
        == "ip link set can1 type can bitrate 500000 sample-point 0.875 sjw 1"
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


def test_sjw_above_tseg2_takes_the_next_closest_split_or_drops_the_row() -> None:
    rows = bittiming.solutions(CLOCK_HZ, 500_000, sjw=2)
    # N = 12 samples at 83.3 % instead of 91.7 % (Seg 2 of 1 cannot hold SJW 2); N = 8 has none.
    assert [(r.brp, r.tseg1, r.tseg2, r.sjw) for r in rows] == [(6, 13, 2, 2), (8, 9, 2, 2)]
    assert rows[0].btr == 0x011C0005


def test_the_ip_link_bitrate_line_keeps_a_non_default_sjw() -> None:
    row = next(r for r in bittiming.solutions(CLOCK_HZ, 500_000, sjw=2) if r.recommended)
    assert row.ip_link_bitrate().endswith("bitrate 500000 sample-point 0.875 sjw 2")
    assert row.ip_link_segments().endswith("phase-seg1 7 phase-seg2 2 sjw 2")


def test_sjw_moves_quanta_from_prop_seg_into_phase_seg1() -> None:
    # 58.3 %: Seg 1 = 6 splits 3 + 3 by default, which cannot hold SJW 4 (Linux >= 6.3 refuses).
    row = BitTiming(CLOCK_HZ, 500_000, brp=8, tseg1=6, tseg2=5, sjw=4)
    assert (row.prop_seg, row.phase_seg1, row.phase_seg2) == (2, 4, 5)
    assert not row.kernel_splits_alike()
    assert BitTiming(CLOCK_HZ, 500_000, brp=8, tseg1=6, tseg2=5, sjw=3).kernel_splits_alike()


def test_no_row_has_an_sjw_its_seg_1_cannot_hold() -> None:
    # 50 % on 8 quanta leaves Seg 1 = 3: SJW 4 fits Seg 2 (4) but not Seg 1.
    rows = bittiming.solutions(8_000_000, 1_000_000, 0.5, sjw=4)
    assert rows == []
    assert [(r.tseg1, r.tseg2) for r in bittiming.solutions(8_000_000, 1_000_000, 0.5, sjw=3)] == [
        (3, 4)
    ]


@pytest.mark.parametrize(
    ("clock_hz", "requested", "boundary"),
    [(40_000_000, 0.75, 0.8), (48_000_000, 0.8, 0.75), (8_000_000, 0.8, 0.75)],
)
def test_a_sample_point_exactly_on_the_tolerance_bound_is_kept(
    clock_hz: int, requested: float, boundary: float
) -> None:
    rows = bittiming.solutions(clock_hz, 500_000, requested)
    assert boundary in [row.sample_point for row in rows]


def test_nearest_prefers_an_exact_bitrate_at_another_sample_point() -> None:
    # 25 MHz / 1 Mbit/s allows only 25 quanta, whose Seg 2 (at most 8) cannot sample at 50 %.
    assert bittiming.solutions(25_000_000, 1_000_000, 0.5) == []
    suggestion = bittiming.nearest(25_000_000, 1_000_000, 0.5)
    assert suggestion is not None
    assert (suggestion.brp, suggestion.tq_count, suggestion.bitrate_error) == (1, 25, 0.0)
    assert suggestion.sample_point == 0.68  # as close to 50 % as Seg 2 <= 8 allows


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


# --- the grid: Linux and python-can --------------------------------------------------------------

GRID_CLOCKS_MHZ = [8, 16, 20, 24, 25, 36, 40, 42, 45, 48, 80]
GRID_SAMPLE_POINTS = [0.5, 0.6, 0.75, 0.8, 0.875, 0.9]
GRID_SJWS = [1, 2, 3, 4]


def _grid() -> list[tuple[int, int, float, int]]:
    rates = bittiming.STANDARD_BITRATES_BPS
    product = itertools.product(GRID_CLOCKS_MHZ, rates, GRID_SAMPLE_POINTS, GRID_SJWS)
    return [
        (mhz * 1_000_000, rate, sample_point, sjw)
        for mhz, rate, sample_point, sjw in product
        if rate in bittiming.bitrate_range_bps(mhz * 1_000_000)
    ]


def _best(clock_hz: int, rate: int, sample_point: float, sjw: int) -> BitTiming | None:
    rows = bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw)
    recommended = next((row for row in rows if row.recommended), None)
    return recommended or bittiming.nearest(clock_hz, rate, sample_point, sjw=sjw)


def test_the_grid_is_large() -> None:
    assert len(_grid()) > 2000


def test_linux_accepts_every_explicit_ip_link_line_as_the_same_timing() -> None:
    checked = 0
    for clock_hz, rate, sample_point, sjw in _grid():
        for row in bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw):
            kernel = linux.can_fixup_bittiming(
                clock_hz,
                row.linux_tq_ns,
                prop_seg=row.prop_seg,
                phase_seg1=row.phase_seg1,
                phase_seg2=row.phase_seg2,
                sjw=row.sjw,
            )
            assert (kernel.brp, kernel.tseg1, kernel.phase_seg2) == (row.brp, row.tseg1, row.tseg2)
            assert (kernel.bitrate, kernel.sjw) == (rate, sjw)
            assert kernel.sample_point == math.floor(row.sample_point * 1000 + 1e-9)
            checked += 1
    assert checked > 5000


def test_linux_runs_every_printed_bitrate_line_at_the_exact_bitrate() -> None:
    printed = 0
    for clock_hz, rate, sample_point, sjw in _grid():
        rows = bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw)
        best = next((row for row in rows if row.recommended), None)
        if best is None or not best.kernel_splits_alike():
            continue
        # `sample-point 0.917` reaches the kernel as 917 per mille
        per_mille = round(best.sample_point * 1000)
        kernel = linux.can_calc_bittiming(clock_hz, rate, per_mille, best.sjw)
        assert kernel.bitrate * kernel.brp * (1 + kernel.tseg1 + kernel.phase_seg2) == clock_hz
        assert kernel.bitrate == rate
        assert kernel.sjw == sjw
        printed += 1
    assert printed > 1000


def test_an_sjw_linux_would_refuse_in_the_bitrate_form_is_flagged() -> None:
    flagged = 0
    for clock_hz, rate, sample_point, sjw in _grid():
        for row in bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw):
            if row.kernel_splits_alike():
                continue
            flagged += 1
            with pytest.raises(linux.KernelRejects, match="greater than phase-seg1"):
                linux.can_fixup_bittiming(
                    clock_hz,
                    row.linux_tq_ns,
                    prop_seg=row.tseg1 // 2,  # as can_calc_bittiming() splits Seg 1
                    phase_seg1=row.tseg1 - row.tseg1 // 2,
                    phase_seg2=row.tseg2,
                    sjw=row.sjw,
                )
    assert flagged > 10


def test_where_linux_finds_an_exact_bitrate_so_does_bywire_and_samples_as_close() -> None:
    compared = 0
    for clock_hz, rate, sample_point, sjw in _grid():
        per_mille = round(sample_point * 1000)
        try:
            kernel = linux.can_calc_bittiming(clock_hz, rate, per_mille, sjw)
        except linux.KernelRejects:
            continue
        quanta = 1 + kernel.tseg1 + kernel.phase_seg2
        if kernel.brp * quanta * rate != clock_hz or quanta < bittiming.TQ_COUNT_RANGE.start:
            continue  # not exact, or fewer quanta than CiA's 8 (which bywire never offers)
        best = _best(clock_hz, rate, sample_point, sjw)
        assert best is not None
        assert best.bitrate_error == 0.0, (clock_hz, rate, sample_point, sjw)
        ours = abs(round(best.sample_point * 1000) - per_mille)
        assert ours <= abs(kernel.sample_point - per_mille) + 1, (clock_hz, rate, sample_point)
        compared += 1
    assert compared > 1500


def test_every_row_is_the_same_timing_for_python_can() -> None:
    checked = 0
    for clock_hz, rate, sample_point, sjw in _grid():
        for row in bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw):
            if row.brp > 64:  # python-can's BitTiming stops at SJA1000's 64
                continue
            theirs = can.BitTiming(clock_hz, row.brp, row.tseg1, row.tseg2, row.sjw)
            assert theirs.bitrate == rate
            assert theirs.sample_point == pytest.approx(row.sample_point * 100)
            assert theirs.nbt == row.tq_count
            checked += 1
    assert checked > 3000


def test_every_exact_python_can_solution_in_tolerance_is_offered() -> None:
    for clock_hz, rate, sample_point, sjw in _grid():
        ours = {
            (r.brp, r.tq_count) for r in bittiming.solutions(clock_hz, rate, sample_point, sjw=sjw)
        }
        for theirs in can.BitTiming.iterate_from_sample_point(clock_hz, rate, sample_point * 100):
            exact = theirs.brp * theirs.nbt * rate == clock_hz
            close = abs(theirs.sample_point - sample_point * 100) <= 5
            if exact and close and min(theirs.tseg1, theirs.tseg2) >= sjw:
                assert (theirs.brp, theirs.nbt) in ours, (clock_hz, rate, sample_point, sjw)


@pytest.mark.parametrize(("dlc", "bits"), [(0, 55), (1, 65), (3, 85), (4, 95), (8, 135)])
def test_frame_bits_include_worst_case_stuffing(dlc: int, bits: int) -> None:
    assert bittiming.frame_bits(dlc) == bits


def test_frame_bits_rejects_more_than_eight_bytes() -> None:
    with pytest.raises(FrameError):
        bittiming.frame_bits(9)


def test_frame_time_is_the_bits_at_the_bitrate() -> None:
    assert bittiming.frame_time_s(8, 500_000) == pytest.approx(135 / 500_000)
