"""A port of Linux's CAN bit-timing code (drivers/net/can/dev/calc_bittiming.c, bittiming.c, 6.3+).

Kept line for line close to the C, unsigned integer arithmetic included, so that the tests can ask
"what does the kernel do with this `ip link` line on a bxCAN?" without a kernel:

* `can_calc_bittiming`: `ip link set can0 type can bitrate B [sample-point S] [sjw J]`
* `can_fixup_bittiming`: `ip link set can0 type can tq T prop-seg P phase-seg1 A phase-seg2 B sjw J`

Both return the resulting `KernelTiming`, or raise `KernelRejects` with the kernel's message.
"""

from __future__ import annotations

from dataclasses import dataclass

CAN_SYNC_SEG = 1
CAN_CALC_MAX_ERROR = 50  # in one-tenth of a percent
UINT_MAX = 0xFFFF_FFFF


@dataclass(frozen=True)
class BittimingConst:
    """`struct can_bittiming_const`."""

    tseg1_min: int
    tseg1_max: int
    tseg2_min: int
    tseg2_max: int
    sjw_max: int
    brp_min: int
    brp_max: int
    brp_inc: int


# drivers/net/can/bxcan.c
BXCAN = BittimingConst(1, 16, 1, 8, 4, 1, 1024, 1)


@dataclass(frozen=True)
class KernelTiming:
    """The fields of `struct can_bittiming` the kernel fills in."""

    bitrate: int
    sample_point: int  # per mille
    tq: int  # ns
    prop_seg: int
    phase_seg1: int
    phase_seg2: int
    sjw: int
    brp: int

    @property
    def tseg1(self) -> int:
        return self.prop_seg + self.phase_seg1


class KernelRejects(ValueError):  # noqa: N818 -- the kernel's -EINVAL, with its message
    """The kernel answers -EINVAL; the message is its extack text."""


def _clamp(value: int, low: int, high: int) -> int:
    return max(low, min(value, high))


def can_update_sample_point(
    btc: BittimingConst, sample_point_nominal: int, tseg: int
) -> tuple[int, int, int, int]:
    """(best_sample_point, tseg1, tseg2, sample_point_error), as the C writes them back."""
    best_sample_point_error = UINT_MAX
    best_sample_point = 0
    best_tseg1 = best_tseg2 = 0
    for i in (0, 1):
        tseg2 = tseg + CAN_SYNC_SEG - (sample_point_nominal * (tseg + CAN_SYNC_SEG)) // 1000 - i
        tseg2 = _clamp(tseg2, btc.tseg2_min, btc.tseg2_max)
        tseg1 = tseg - tseg2
        if tseg1 > btc.tseg1_max:
            tseg1 = btc.tseg1_max
            tseg2 = tseg - tseg1
        sample_point = 1000 * (tseg + CAN_SYNC_SEG - tseg2) // (tseg + CAN_SYNC_SEG)
        sample_point_error = abs(sample_point_nominal - sample_point)
        if sample_point <= sample_point_nominal and sample_point_error < best_sample_point_error:
            best_sample_point = sample_point
            best_sample_point_error = sample_point_error
            best_tseg1, best_tseg2 = tseg1, tseg2
    return best_sample_point, best_tseg1, best_tseg2, best_sample_point_error


def can_sjw_set_default(sjw: int, phase_seg1: int, phase_seg2: int) -> int:
    """With no sjw from user space, phase-seg2 / 2 (at least 1, at most phase-seg1)."""
    if sjw:
        return sjw
    return max(1, min(phase_seg1, phase_seg2 // 2))


def can_sjw_check(btc: BittimingConst, sjw: int, phase_seg1: int, phase_seg2: int) -> None:
    if sjw > btc.sjw_max:
        raise KernelRejects(f"sjw: {sjw} greater than max sjw: {btc.sjw_max}")
    if sjw > phase_seg1:
        raise KernelRejects(f"sjw: {sjw} greater than phase-seg1: {phase_seg1}")
    if sjw > phase_seg2:
        raise KernelRejects(f"sjw: {sjw} greater than phase-seg2: {phase_seg2}")


def can_calc_bittiming(
    clock_freq: int, bitrate: int, sample_point: int = 0, sjw: int = 0, btc: BittimingConst = BXCAN
) -> KernelTiming:
    """`bitrate B [sample-point S/1000] [sjw J]` -> the timing the kernel programs."""
    best_bitrate_error = UINT_MAX
    best_sample_point_error = UINT_MAX
    best_tseg = best_brp = 0

    if sample_point:
        sample_point_nominal = sample_point
    elif bitrate > 800_000:
        sample_point_nominal = 750
    elif bitrate > 500_000:
        sample_point_nominal = 800
    else:
        sample_point_nominal = 875

    # tseg even = round down, odd = round up
    tseg = (btc.tseg1_max + btc.tseg2_max) * 2 + 1
    while tseg >= (btc.tseg1_min + btc.tseg2_min) * 2:
        tsegall = CAN_SYNC_SEG + tseg // 2
        brp = clock_freq // (tsegall * bitrate) + tseg % 2
        brp = (brp // btc.brp_inc) * btc.brp_inc
        if brp < btc.brp_min or brp > btc.brp_max:
            tseg -= 1
            continue
        current_bitrate = clock_freq // (brp * tsegall)
        bitrate_error = abs(bitrate - current_bitrate)
        if bitrate_error > best_bitrate_error:
            tseg -= 1
            continue
        if bitrate_error < best_bitrate_error:
            best_sample_point_error = UINT_MAX
        _sp, _t1, _t2, sample_point_error = can_update_sample_point(
            btc, sample_point_nominal, tseg // 2
        )
        if sample_point_error >= best_sample_point_error:
            tseg -= 1
            continue
        best_sample_point_error = sample_point_error
        best_bitrate_error = bitrate_error
        best_tseg = tseg // 2
        best_brp = brp
        if bitrate_error == 0 and sample_point_error == 0:
            break
        tseg -= 1

    if best_bitrate_error:
        error_per_mille = best_bitrate_error * 1000 // bitrate
        if error_per_mille > CAN_CALC_MAX_ERROR:
            raise KernelRejects(
                f"bitrate error: {error_per_mille // 10}.{error_per_mille % 10}% too high"
            )

    real_sample_point, tseg1, tseg2, _error = can_update_sample_point(
        btc, sample_point_nominal, best_tseg
    )
    tq = best_brp * 1_000_000_000 // clock_freq
    prop_seg = tseg1 // 2
    phase_seg1 = tseg1 - prop_seg
    phase_seg2 = tseg2
    sjw = can_sjw_set_default(sjw, phase_seg1, phase_seg2)
    can_sjw_check(btc, sjw, phase_seg1, phase_seg2)  # can_validate_bittiming() after the calc
    real_bitrate = clock_freq // (best_brp * (CAN_SYNC_SEG + tseg1 + tseg2))
    return KernelTiming(
        real_bitrate, real_sample_point, tq, prop_seg, phase_seg1, phase_seg2, sjw, best_brp
    )


def can_fixup_bittiming(
    clock_freq: int,
    tq: int,
    *,
    prop_seg: int,
    phase_seg1: int,
    phase_seg2: int,
    sjw: int = 0,
    btc: BittimingConst = BXCAN,
) -> KernelTiming:
    """`tq T prop-seg P phase-seg1 A phase-seg2 B [sjw J]` -> the timing, or KernelRejects."""
    tseg1 = prop_seg + phase_seg1
    if tseg1 < btc.tseg1_min:
        raise KernelRejects(f"prop-seg + phase-seg1: {tseg1} less than tseg1-min")
    if tseg1 > btc.tseg1_max:
        raise KernelRejects(f"prop-seg + phase-seg1: {tseg1} greater than tseg1-max")
    if phase_seg2 < btc.tseg2_min:
        raise KernelRejects(f"phase-seg2: {phase_seg2} less than tseg2-min")
    if phase_seg2 > btc.tseg2_max:
        raise KernelRejects(f"phase-seg2: {phase_seg2} greater than tseg2-max")
    sjw = can_sjw_set_default(sjw, phase_seg1, phase_seg2)
    can_sjw_check(btc, sjw, phase_seg1, phase_seg2)
    brp64 = clock_freq * tq
    if btc.brp_inc > 1:
        brp64 //= btc.brp_inc
    brp64 = (brp64 + 500_000_000 - 1) // 1_000_000_000  # the practicable BRP
    if btc.brp_inc > 1:
        brp64 *= btc.brp_inc
    brp = brp64
    if brp < btc.brp_min or brp > btc.brp_max:
        raise KernelRejects(f"resulting brp {brp} out of range")
    bit_time = CAN_SYNC_SEG + tseg1 + phase_seg2
    sample_point = (CAN_SYNC_SEG + tseg1) * 1000 // bit_time
    bitrate = clock_freq // (brp * bit_time)
    return KernelTiming(bitrate, sample_point, tq, prop_seg, phase_seg1, phase_seg2, sjw, brp)
