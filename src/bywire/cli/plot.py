"""`bywire plot LOG`: a PNG of a CAN log (BLF, Vector ASC, candump -L) decoded with the DBC."""

from __future__ import annotations

import argparse
from pathlib import Path

from bywire.protocol import dbc
from bywire.tools.log_decode import FORMATS, check_log_suffix, read_can_log
from bywire.tools.logplot import write_log_plot


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "log", type=Path, metavar="LOG", help=f"CAN log: .blf, .asc or .log ({FORMATS})"
    )
    parser.add_argument(
        "--out",
        type=Path,
        metavar="FILE.png",
        help="where to write the plot (default: LOG with .png)",
    )
    parser.add_argument(
        "--dbc",
        type=Path,
        metavar="FILE",
        help="CAN database to decode with (default: the packaged one)",
    )


def run(args: argparse.Namespace) -> int:
    """Figures are drawn without pyplot (Agg through `Figure.savefig`): no display needed."""
    log_path: Path = args.log
    check_log_suffix(log_path)
    out: Path = args.out or log_path.with_suffix(".png")
    database = dbc.database() if args.dbc is None else dbc.load_database(args.dbc)
    log = read_can_log(log_path, database)
    title = (
        f"bywire plot: {log_path.name}: {log.frames} frames over {log.duration_s:.1f} s"
        f" ({log.unknown_frames} not in the DBC, {log.undecodable_frames} undecodable)"
    )
    write_log_plot(log, out, title)
    print(f"Plot: {out}")
    return 0
