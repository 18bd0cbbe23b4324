"""bxCAN bit timing: every exact prescaler/segment setting for a bitrate, with CAN_BTR and ip link.

One CAN bit is N time quanta (thesis §4.3.2, Figure 19); tq = BRP / clock:

    |<--------------------- N = 1 + TS1 + TS2 quanta ---------------------->|
    +------+------------------------------------------+---------------------+
    | SYNC |  TS1 = Linux prop-seg + phase-seg1       | TS2 = phase-seg2    |
    +------+------------------------------------------+---------------------+
     1 tq                                             ^ sample point = (1 + TS1) / N

    CAN_BTR:  31..26  25..24  23  22..20  19..16  15..10  9..0
             +------+-------+---+-------+-------+------+-------+
             |  -   | SJW-1 | - | TS2-1 | TS1-1 |  -   | BRP-1 |
             +------+-------+---+-------+-------+------+-------+

Rows follow Figure 20 (bittiming.can-wiki.info; rule inferred from its rows): for each prescaler
that divides the bit into a whole number N of quanta, the sample point sits at
round-half-up(sample_point * N) quanta, so TS1 = that - 1 and TS2 = N - that (N = 12 at 87.5 %:
10.5 -> 11 -> TS1 10, TS2 1, 91.7 %). A row is valid when 8 <= N <= 25 (CiA asks for at least 8
quanta; 25 = 1 + 16 + 8 is the bxCAN maximum), BRP, TS1, TS2 and SJW <= TS1, TS2 fit the bxCAN
limits, and the sample point lies within SAMPLE_POINT_TOLERANCE of the request, bounds included
(compared as exact fractions: 80 % is 5 points off 75 %, not 5.000000000000004). 5 points keeps
Figure 20's 91.7 % rows (4.2 points off 87.5 %) and drops only coarse 8-9 quanta settings whose
rounding lands further away.

Linux sees TS1 as prop-seg + phase-seg1 and (since 6.3) rejects SJW > phase-seg1 or > phase-seg2;
prop-seg is TS1 // 2 as in can_calc_bittiming(), moved into phase-seg1 as far as SJW needs, and a
setting whose TS1 cannot hold SJW is not offered. When no setting is exact at the requested
sample point, `nearest` ranks as can_calc_bittiming() does: bitrate error first, then sample
point error, so an exact bitrate at another sample point beats a bitrate a few per cent off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from functools import cache

from bywire.errors import ConfigError, FrameError

BRP_RANGE = range(1, 1025)
TSEG1_RANGE = range(1, 17)
TSEG2_RANGE = range(1, 9)
SJW_RANGE = range(1, 5)
TQ_COUNT_RANGE = range(8, 26)
SAMPLE_POINT_MIN = 0.5
SAMPLE_POINT_MAX = 0.95
SAMPLE_POINT_TOLERANCE = 0.05
STANDARD_BITRATES_BPS = (
    1_000_000,
    800_000,
    500_000,
    250_000,
    125_000,
    100_000,
    50_000,
    20_000,
    10_000,
)
_NS_PER_S = 1_000_000_000


def frame_bits(dlc: int) -> int:
    """Bits a classic base-format data frame holds on the bus, worst-case stuffing included.

    47 fixed bits (SOF, 11-bit id, RTR, IDE, r0, DLC, 15-bit CRC, CRC and ACK delimiters, ACK
    slot, 7-bit EOF, 3-bit intermission) plus 8 per data byte, plus one stuff bit per 4 bits of
    the 34 + 8 * dlc bits from SOF to the end of the CRC (Davis et al. 2007): 135 bits for 8 bytes.
    """
    if not 0 <= dlc <= 8:
        raise FrameError(f"classic CAN carries 0..8 data bytes, got {dlc}")
    stuffable_bits = 34 + 8 * dlc
    return 47 + 8 * dlc + (stuffable_bits - 1) // 4


def frame_time_s(dlc: int, bitrate_bps: int) -> float:
    """Seconds a classic base-format frame of `dlc` data bytes holds the bus at `bitrate_bps`,
    worst-case stuffing included (`frame_bits`)."""
    return frame_bits(dlc) / bitrate_bps


@dataclass(frozen=True)
class BitTiming:
    """One bxCAN setting for `bitrate_bps` (requested) on a `clock_hz` peripheral clock."""

    clock_hz: int
    bitrate_bps: int
    brp: int
    tseg1: int
    tseg2: int
    sjw: int = 1
    recommended: bool = False

    @property
    def tq_count(self) -> int:
        """Time quanta per bit: SYNC (1) + TS1 + TS2."""
        return 1 + self.tseg1 + self.tseg2

    @property
    def sample_point(self) -> float:
        """Where the bit is sampled, as a fraction of the bit time."""
        return (1 + self.tseg1) / self.tq_count

    @property
    def btr(self) -> int:
        """The STM32 CAN_BTR value (timing fields only; LBKM and SILM left 0)."""
        fields = (self.sjw - 1) << 24 | (self.tseg2 - 1) << 20 | (self.tseg1 - 1) << 16
        return fields | (self.brp - 1)

    @property
    def tq_ns(self) -> float:
        """Length of one time quantum in nanoseconds (exact)."""
        return self.brp * _NS_PER_S / self.clock_hz

    @property
    def actual_bitrate_bps(self) -> float:
        return self.clock_hz / (self.brp * self.tq_count)

    @property
    def bitrate_error(self) -> float:
        """(actual - requested) / requested; 0.0 for every row `solutions` returns."""
        return self.actual_bitrate_bps / self.bitrate_bps - 1.0

    @property
    def phase_seg1(self) -> int:
        """Half of TS1 (the larger half), or SJW when SJW needs more: Linux wants SJW <= it."""
        return min(self.tseg1, max(self.tseg1 - self.tseg1 // 2, self.sjw))

    @property
    def prop_seg(self) -> int:
        return self.tseg1 - self.phase_seg1

    @property
    def phase_seg2(self) -> int:
        return self.tseg2

    @property
    def linux_tq_ns(self) -> int:
        """tq for `ip link`, rounded to whole ns as the kernel reports it; the kernel rounds
        clock * tq back to the nearest prescaler, which recovers `brp` on this clock."""
        return (self.brp * _NS_PER_S + self.clock_hz // 2) // self.clock_hz

    def kernel_splits_alike(self) -> bool:
        """Whether Linux's own split of TS1 (phase-seg1 = TS1 - TS1 // 2) can hold SJW.

        When it cannot, `ip link ... bitrate ... sjw N` is refused (Linux >= 6.3: "sjw greater
        than phase-seg1") and only the explicit tq form works.
        """
        return self.sjw <= self.tseg1 - self.tseg1 // 2

    def ip_link_bitrate(self, channel: str = "can0") -> str:
        """The portable form: the kernel picks its own controller's prescaler.

        SJW is always given: left out, Linux < 6.3 uses 1 and Linux >= 6.3 phase-seg2 / 2, so the
        link would not run with the SJW of this row.
        """
        sample_point = f"{self.sample_point:.3f}".rstrip("0")
        bitrate = f"bitrate {self.bitrate_bps} sample-point {sample_point} sjw {self.sjw}"
        return f"ip link set {channel} type can {bitrate}"

    def ip_link_segments(self, channel: str = "can0") -> str:
        """The explicit form; exact only on a controller that can make this tq."""
        phases = f"phase-seg1 {self.phase_seg1} phase-seg2 {self.phase_seg2}"
        segments = f"tq {self.linux_tq_ns} prop-seg {self.prop_seg} {phases} sjw {self.sjw}"
        return f"ip link set {channel} type can {segments}"


def solutions(
    clock_hz: int,
    bitrate_bps: int,
    sample_point: float = 0.875,
    *,
    sjw: int = 1,
    sample_point_tolerance: float = SAMPLE_POINT_TOLERANCE,
) -> list[BitTiming]:
    """Every exact setting for the bitrate, prescaler ascending, the best one `recommended`.

    Empty if no prescaler gives a whole number of quanta; ConfigError for impossible inputs.
    """
    request = _Request(clock_hz, bitrate_bps, sample_point, sjw, sample_point_tolerance)
    rows = []
    for tq_count in reversed(TQ_COUNT_RANGE):
        brp, remainder = divmod(clock_hz, bitrate_bps * tq_count)
        row = request.row(brp, tq_count)
        if row is not None and not remainder:
            rows.append(row)
    return _mark_recommended(rows, sample_point)


def table(
    clock_hz: int,
    bitrates_bps: tuple[int, ...] = STANDARD_BITRATES_BPS,
    sample_point: float = 0.875,
    *,
    sjw: int = 1,
) -> list[BitTiming]:
    """Figure 20: the solutions for several bitrates, bitrate descending, prescaler ascending."""
    ordered = sorted(bitrates_bps, reverse=True)
    return [row for rate in ordered for row in solutions(clock_hz, rate, sample_point, sjw=sjw)]


def nearest(
    clock_hz: int, bitrate_bps: int, sample_point: float = 0.875, *, sjw: int = 1
) -> BitTiming | None:
    """The valid setting closest to the request when `solutions` has none.

    Ranked as Linux's can_calc_bittiming() ranks: bitrate error first, then the sample point's
    distance from the request (any sample point the limits allow), then more quanta.
    """
    request = _Request(clock_hz, bitrate_bps, sample_point, sjw)
    candidates = [
        row
        for tq_count in TQ_COUNT_RANGE
        for brp in _nearby_prescalers(clock_hz / (bitrate_bps * tq_count))
        if (row := request.closest_row(brp, tq_count)) is not None
    ]
    ranked = sorted(candidates, key=lambda row: _rank(row, sample_point, exact_first=True))
    return replace(ranked[0], recommended=True) if ranked else None


def bitrate_range_bps(clock_hz: int) -> range:
    """Bitrates a clock can reach at all: 8 quanta at BRP 1 down to 25 quanta at BRP 1024."""
    if clock_hz < TQ_COUNT_RANGE.start:
        raise ConfigError(f"clock must be >= 8 Hz (8 quanta at prescaler 1), got {clock_hz} Hz")
    slowest = math.ceil(clock_hz / (BRP_RANGE[-1] * TQ_COUNT_RANGE[-1]))
    return range(slowest, clock_hz // TQ_COUNT_RANGE.start + 1)


@dataclass(frozen=True)
class _Request:
    """What the caller asked for, checked once; builds the row for one prescaler and N."""

    clock_hz: int
    bitrate_bps: int
    sample_point: float
    sjw: int
    tolerance: float = SAMPLE_POINT_TOLERANCE

    def __post_init__(self) -> None:
        _check_inputs(self.clock_hz, self.bitrate_bps, self.sample_point, self.sjw)

    def row(self, brp: int, tq_count: int) -> BitTiming | None:
        """The setting for this prescaler and N, or None if none fits the limits and tolerance."""
        row = self.closest_row(brp, tq_count)
        if row is None or abs(_position(row) - _exact(self.sample_point)) > _exact(self.tolerance):
            return None
        return row

    def closest_row(self, brp: int, tq_count: int) -> BitTiming | None:
        """The setting for this prescaler and N whose sample point is closest to the request.

        A tie rounds half up (N = 12 at 87.5 %: 10.5 -> 11 quanta, Figure 20's 91.7 %); when SJW
        or a segment limit rules that split out, the next closest one is taken (83.3 %).
        """
        # Exact arithmetic: 0.875 * 12 must be 10.5, whatever the float error.
        half_up = math.floor(_exact(self.sample_point) * tq_count + Fraction(1, 2))
        # Sampling after q quanta: Seg 1 = q - 1 and Seg 2 = N - q must fit and hold SJW.
        lowest = max(TSEG1_RANGE.start, self.sjw) + 1
        highest = tq_count - max(TSEG2_RANGE.start, self.sjw)
        lowest = max(lowest, tq_count - TSEG2_RANGE[-1])
        highest = min(highest, TSEG1_RANGE[-1] + 1)
        if brp not in BRP_RANGE or lowest > highest:
            return None
        sample_quanta = min(max(half_up, lowest), highest)  # the closest allowed split
        tseg1, tseg2 = sample_quanta - 1, tq_count - sample_quanta
        return BitTiming(self.clock_hz, self.bitrate_bps, brp, tseg1, tseg2, self.sjw)


@cache
def _exact(value: float) -> Fraction:
    """A sample point or tolerance as the decimal fraction the user meant (0.875 = 7/8)."""
    return Fraction(value).limit_denominator(10_000)


def _position(row: BitTiming) -> Fraction:
    return Fraction(1 + row.tseg1, row.tq_count)


def _mark_recommended(rows: list[BitTiming], sample_point: float) -> list[BitTiming]:
    if not rows:
        return rows
    best = min(rows, key=lambda row: _rank(row, sample_point, exact_first=False))
    return [replace(row, recommended=row is best) for row in rows]


def _rank(row: BitTiming, sample_point: float, *, exact_first: bool) -> tuple[Fraction, ...]:
    # Closest sample point first, then more quanta: finer resynchronisation steps.
    rate_error = abs(Fraction(row.clock_hz, row.brp * row.tq_count) - row.bitrate_bps)
    distance = abs(_position(row) - _exact(sample_point))
    return (rate_error if exact_first else Fraction(0), distance, Fraction(-row.tq_count))


def _nearby_prescalers(ideal_brp: float) -> set[int]:
    below, above = math.floor(ideal_brp), math.ceil(ideal_brp)
    return {max(BRP_RANGE.start, min(BRP_RANGE[-1], brp)) for brp in (below, above)}


def _check_inputs(clock_hz: int, bitrate_bps: int, sample_point: float, sjw: int) -> None:
    reachable = bitrate_range_bps(clock_hz)
    if not SAMPLE_POINT_MIN <= sample_point <= SAMPLE_POINT_MAX:
        raise ConfigError(f"sample point must be 0.5..0.95 (50..95 %), got {sample_point}")
    if sjw not in SJW_RANGE:
        raise ConfigError(f"sjw must be 1..4 quanta (bxCAN), got {sjw}")
    if bitrate_bps not in reachable:
        raise ConfigError(
            f"bitrate must be {reachable.start}..{reachable.stop - 1} bit/s with a {clock_hz} Hz"
            f" clock (8..25 quanta, prescaler 1..1024), got {bitrate_bps} bit/s"
        )
