"""`bywire monitor`: the bus decoded with the DBC, live (textual) or as one snapshot table.

Connects with any python-can interface; by default to the simulator's transport
(`bywire sim --realtime --serve 29536`) over socketcand on loopback.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from bywire.cli.arguments import add_snapshot_options, snapshot_s
from bywire.cli.bus_options import add_bus_options, bus_from_args, bus_source
from bywire.cli.console import stdout_console
from bywire.monitor.bus_reader import CanFeed
from bywire.monitor.bus_state import BusModel
from bywire.monitor.view import snapshot_table

SNAPSHOT_S = 1.0


def configure(parser: argparse.ArgumentParser) -> None:
    add_bus_options(parser)
    parser.add_argument(
        "--record",
        type=Path,
        metavar="FILE.blf|.asc|.log|.trc|.csv|.mf4",
        help="also write every frame (BLF, Vector ASC or candump -L, by suffix)",
    )
    add_snapshot_options(parser, SNAPSHOT_S, "the table")


def run(args: argparse.Namespace) -> int:
    # python-can logs what it skips ("Got incomplete message") over the screen: the feed shows
    # what matters (a lost connection) in the title instead.
    logging.getLogger("can").setLevel(logging.ERROR)
    feed = CanFeed(bus_from_args(args), args.record, reopen=lambda: bus_from_args(args))
    source = bus_source(args)
    listen_s = snapshot_s(args, SNAPSHOT_S)
    if listen_s is not None:
        return _snapshot(feed, source, listen_s)
    from bywire.monitor.app import MonitorApp  # noqa: PLC0415 -- textual: live view only

    feed.start()
    try:
        MonitorApp(feed, BusModel(), source).run()
    finally:
        feed.stop()
    return 0


def _snapshot(feed: CanFeed, source: str, duration_s: float) -> int:
    model = BusModel()
    feed.start()
    try:
        time.sleep(duration_s)
    finally:
        feed.stop()
    for message in feed.drain():
        model.add(message.arbitration_id, bytes(message.data), message.timestamp)
    title = f"{source} ({feed.connection}): {model.frames} frames in {duration_s:g} s"
    stdout_console().print(snapshot_table(model.rows(time.time()), title), soft_wrap=True)
    return 0 if model.frames else 1
