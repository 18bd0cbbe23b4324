"""`bywire plot LOG`: a PNG of a CAN log (BLF, ASC, TRC, MF4, CSV, candump) decoded with a DBC."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bywire.canlog.plot import check_png_path, choose_signals, is_albert_log, write_log_plot
from bywire.canlog.read import FORMATS, SUFFIXES, check_log_suffix, read_can_log
from bywire.cli.dbc import load_user_dbc
from bywire.protocol import dbc


def configure(parser: argparse.ArgumentParser) -> None:
    parser.epilog = (
        "Without --signal, a log of albert.dbc's messages gets Albert's view (commands, steering,"
        " speeds, lights, mode); any other log the signals that change (counters and checksums"
        " left out, at most 12), one panel per unit."
    )
    parser.add_argument(
        "log", type=Path, metavar="LOG", help=f"CAN log: {' '.join(SUFFIXES)} ({FORMATS})"
    )
    parser.add_argument(
        "--out",
        type=Path,
        metavar="FILE.png",
        help="where to write the plot (default: LOG with .png)",
    )
    parser.add_argument(
        "--force", action="store_true", help="overwrite the PNG if it exists (refused otherwise)"
    )
    parser.add_argument(
        "--dbc",
        type=Path,
        metavar="FILE",
        help="CAN database to decode with (default: the packaged albert.dbc)",
    )
    parser.add_argument(
        "--signal",
        action="append",
        default=[],
        metavar="MESSAGE.SIGNAL",
        help="signal to draw (repeatable; globs such as 'DI_*.*Speed*'; without a dot, any"
        " message's signal of that name)",
    )


def run(args: argparse.Namespace) -> int:
    """Figures are drawn without pyplot (Agg through `Figure.savefig`): no display needed."""
    log_path: Path = args.log
    check_log_suffix(log_path)
    out: Path = args.out or log_path.with_suffix(".png")
    check_png_path(out, force=args.force)
    database = dbc.database() if args.dbc is None else load_user_dbc(args.dbc, "plot")
    log = read_can_log(log_path, database)
    if log.stopped is not None:
        print(f"bywire plot: warning: {log_path.name}: {log.stopped}", file=sys.stderr)
    choice = None
    if args.signal or not is_albert_log(log):
        choice = choose_signals(log, database, args.signal)
    span = f"{log.duration_s:.1f} s" if log.timed else "no timestamps"
    title = (
        f"bywire plot: {log_path.name}: {log.frames} frames ({span}),"
        f" {log.unknown_frames} not in the DBC, {log.undecodable_frames} undecodable"
    )
    if choice is not None and choice.defaulted and len(choice.signals) < choice.offered:
        title += f"\n{len(choice.signals)} of {choice.offered} signals: choose with --signal"
    if log.stopped is not None:
        title += "\nread up to a cut: " + log.stopped
    write_log_plot(log, out, title, choice)
    print(f"Plot: {out}")
    return 0
