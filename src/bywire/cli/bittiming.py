"""`bywire bittiming`: the bxCAN bit-timing table of thesis Figure 20, plus ip-link settings."""

from __future__ import annotations

import argparse
import json
import re
from dataclasses import asdict, dataclass
from decimal import Decimal
from typing import Any

from bywire.errors import ConfigError
from bywire.protocol import bittiming
from bywire.protocol.bittiming import BitTiming

_PREFIXES = {"": 1, "k": 1_000, "m": 1_000_000}
_NUMBER = r"\s*(\d+(?:\.\d*)?|\.\d+)\s*"
_CLOCK = re.compile(_NUMBER + r"([km]?)(?:hz)?\s*", re.IGNORECASE)
_BITRATE = re.compile(_NUMBER + r"([km]?)(?:bps|bit/s|b/s)?\s*", re.IGNORECASE)
_BARE_NUMBER = re.compile(_NUMBER)
_SAMPLE_POINT = re.compile(_NUMBER + r"(%?)\s*")
_HEADERS = ["", "Bit Rate", "accuracy", "Pre-scaler", "Number of time quanta", "Seg 1"]
_HEADERS += ["Seg 2", "Sample Point at", "Register CAN_BTR", "tq", "prop-seg", "phase-seg1"]
_HEADERS += ["phase-seg2", "sjw"]
_STANDARD_RATES = "1M, 800k, 500k, 250k, 125k, 100k, 50k, 20k, 10k"


@dataclass(frozen=True)
class _Options:
    clock_hz: int
    bitrates_bps: tuple[int, ...]
    sample_point: float
    sjw: int
    channel: str


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the options of `bywire bittiming`."""
    parser.epilog = (
        "Rows marked * are recommended (sample point closest to the request, then most quanta)."
        " Exit status 1 if --bitrate has no setting within 5 points of the sample point (the"
        " nearest one is suggested), or if no bitrate of the survey has one."
    )
    parser.add_argument(
        "--clock",
        required=True,
        metavar="FREQ",
        help="clock of the CAN peripheral (APB1), e.g. 48MHz, 48M, 48000k or 48000000;"
        " a bare number below 1000 is MHz (48 = 48 MHz)",
    )
    parser.add_argument(
        "--sample-point",
        default="87.5",
        metavar="SP",
        help="requested sample point, percent (87.5) or fraction (0.875), 50..95 %% (default 87.5)",
    )
    parser.add_argument(
        "--bitrate",
        metavar="RATE",
        help=f"one bitrate, e.g. 500k, 500000 or 1M (default: the standard {_STANDARD_RATES})",
    )
    parser.add_argument(
        "--sjw", default="1", metavar="TQ", help="resynchronisation jump width, 1..4 tq (default 1)"
    )
    parser.add_argument(
        "--channel", default="can0", help="SocketCAN interface in the ip link lines (default can0)"
    )
    parser.add_argument("--json", action="store_true", help="print machine-readable JSON")


def run(args: argparse.Namespace) -> int:
    """Print the table (or JSON); 1 if a single requested bitrate has no exact setting."""
    options = _parse(args)
    rows = {rate: _solutions(options, rate) for rate in options.bitrates_bps}
    if args.json:
        print(json.dumps(_as_json(options, rows), indent=2))
    else:
        print(_render(options, rows))
    return 0 if any(rows.values()) else 1


def parse_clock_hz(text: str) -> int:
    """'48MHz', '48M', '48000k', '48000000' or '48' -> 48000000.

    A bare number below 1000 is MHz: no CAN controller runs on a clock of a few hundred Hz, and
    `--clock 48` means the 48 MHz of a datasheet.
    """
    bare = _BARE_NUMBER.fullmatch(text)
    if bare is not None and Decimal(bare[1]) < 1000:
        text = f"{bare[1]}M"
    return _parse_quantity(text, _CLOCK, "clock", "48MHz, 48M, 48000k or 48000000")


def parse_bitrate_bps(text: str) -> int:
    """'500k', '500000', '1M' or '500kbit/s' -> bit/s."""
    return _parse_quantity(text, _BITRATE, "bitrate", "500k, 500000, 1M or 500kbit/s")


def parse_sample_point(text: str) -> float:
    """'87.5', '87.5%' or '0.875' -> 0.875 (a value above 1 is a percentage)."""
    match = _SAMPLE_POINT.fullmatch(text)
    if match is None:
        raise ConfigError(f"sample point {text!r}: use percent (87.5) or a fraction (0.875)")
    value = Decimal(match[1])
    return float(value / 100 if match[2] or value > 1 else value)


def _parse_quantity(text: str, pattern: re.Pattern[str], name: str, examples: str) -> int:
    match = pattern.fullmatch(text)
    value = Decimal(match[1]) * _PREFIXES[match[2].lower()] if match else None
    if value is None or value != value.to_integral_value():
        raise ConfigError(
            f"{name} {text!r}: use a whole number with optional k or M, e.g. {examples}"
        )
    return int(value)


def _parse(args: argparse.Namespace) -> _Options:
    rates: tuple[int, ...] = bittiming.STANDARD_BITRATES_BPS
    if args.bitrate is not None:
        rates = (parse_bitrate_bps(args.bitrate),)
    if not re.fullmatch(r"\s*\d+\s*", args.sjw):
        raise ConfigError(f"sjw {args.sjw!r}: use a whole number of time quanta, 1..4")
    sample_point = parse_sample_point(args.sample_point)
    return _Options(parse_clock_hz(args.clock), rates, sample_point, int(args.sjw), args.channel)


def _solutions(options: _Options, rate_bps: int) -> list[BitTiming]:
    try:
        return bittiming.solutions(
            options.clock_hz, rate_bps, options.sample_point, sjw=options.sjw
        )
    except ConfigError:
        # A survey of standard rates skips those the clock cannot reach; _missing says so.
        survey = len(options.bitrates_bps) > 1
        if survey and rate_bps not in bittiming.bitrate_range_bps(options.clock_hz):
            return []
        raise


def _render(options: _Options, rows: dict[int, list[BitTiming]]) -> str:
    lines = [
        f"bxCAN bit timing: clock {options.clock_hz / 1e6:g} MHz,"
        f" sample point {options.sample_point * 100:g} %, SJW {options.sjw} tq",
        "Bit Rate in kbit/s, accuracy and Sample Point in %; tq (ns) to sjw are the ip link"
        " parameters; * = recommended",
        "",
    ]
    cells = [_cells(row) for rate_rows in rows.values() for row in rate_rows]
    lines += _align([_HEADERS, *cells]) if cells else []
    lines += [_missing(options, rate) for rate, found in rows.items() if not found]
    if len(rows) == 1:
        lines += _ip_link_lines(options, next(iter(rows.values())))
    return "\n".join(lines)


def _cells(row: BitTiming) -> list[str]:
    return [
        "*" if row.recommended else "",
        f"{row.bitrate_bps / 1000:g}",
        f"{row.bitrate_error * 100:.4f}",
        str(row.brp),
        str(row.tq_count),
        str(row.tseg1),
        str(row.tseg2),
        f"{row.sample_point * 100:.1f}",
        f"{row.btr:#010x}",
        str(row.linux_tq_ns),
        str(row.prop_seg),
        str(row.phase_seg1),
        str(row.phase_seg2),
        str(row.sjw),
    ]


def _align(table: list[list[str]]) -> list[str]:
    widths = [max(len(row[column]) for row in table) for column in range(len(table[0]))]
    return [
        "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()
        for row in table
    ]


def _missing(options: _Options, rate_bps: int) -> str:
    text = f"no exact setting for {rate_bps} bit/s with a {options.clock_hz} Hz clock"
    if rate_bps not in bittiming.bitrate_range_bps(options.clock_hz):
        return f"{text} (reachable: {_range_text(options.clock_hz)})"
    text += f" at sample point {options.sample_point * 100:g} % +- 5 and SJW {options.sjw}"
    near = bittiming.nearest(options.clock_hz, rate_bps, options.sample_point, sjw=options.sjw)
    if near is None:
        return f"{text}, and none nearby within the bxCAN limits"
    return (
        f"{text}; nearest: prescaler {near.brp} x {near.tq_count} tq ="
        f" {near.actual_bitrate_bps:.0f} bit/s ({near.bitrate_error * 100:+.4f} %)"
        f" at sample point {near.sample_point * 100:.1f} %, Seg 1 {near.tseg1}, Seg 2"
        f" {near.tseg2}, CAN_BTR {near.btr:#010x}"
    )


def _range_text(clock_hz: int) -> str:
    reachable = bittiming.bitrate_range_bps(clock_hz)
    return f"{reachable.start}..{reachable.stop - 1} bit/s"


def _ip_link_lines(options: _Options, rows: list[BitTiming]) -> list[str]:
    best = next((row for row in rows if row.recommended), None)
    if best is None:
        return []
    lines = [
        "",
        f"Recommended: prescaler {best.brp}, Seg 1 {best.tseg1}, Seg 2 {best.tseg2},"
        f" CAN_BTR {best.btr:#010x}. On the Linux side:",
    ]
    if best.kernel_splits_alike():
        lines.append(f"  {best.ip_link_bitrate(options.channel)}")
    else:
        lines.append(
            f"  (not `bitrate {best.bitrate_bps} ... sjw {best.sjw}`: Linux would split Seg 1"
            f" into phase-seg1 {best.tseg1 - best.tseg1 // 2} < sjw {best.sjw} and refuse it)"
        )
    return [*lines, f"  {best.ip_link_segments(options.channel)}"]


def _as_json(options: _Options, rows: dict[int, list[BitTiming]]) -> dict[str, Any]:
    return {
        "clock_hz": options.clock_hz,
        "sample_point": options.sample_point,
        "sjw": options.sjw,
        "rows": [_row_json(row, options.channel) for found in rows.values() for row in found],
        "no_exact_setting_bps": [rate for rate, found in rows.items() if not found],
    }


def _row_json(row: BitTiming, channel: str) -> dict[str, Any]:
    derived = {
        "tq_count": row.tq_count,
        "sample_point": row.sample_point,
        "btr": f"{row.btr:#010x}",
        "bitrate_error": row.bitrate_error,
        "tq_ns": row.tq_ns,
    }
    ip_link = [row.ip_link_segments(channel)]
    if row.kernel_splits_alike():
        ip_link.insert(0, row.ip_link_bitrate(channel))
    return {**asdict(row), **derived, "ip_link": ip_link}
