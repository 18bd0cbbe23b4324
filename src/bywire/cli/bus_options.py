"""The bus options every tool that opens a CAN bus takes, spelt as python-can's and cantools'
own tools spell them: `-i/--interface`, `-c/--channel`, `--bus-kwargs KEY=VALUE …`, plus
`--host/--port` for the simulator's socketcand server and `--bitrate` for adapters that set it.
"""

from __future__ import annotations

import argparse
from typing import Any

import can

from bywire.loopback import DEFAULT_HOST, DEFAULT_PORT
from bywire.monitor.bus_reader import open_bus


def _keyword(text: str) -> tuple[str, Any]:
    """KEY=VALUE, the value as python-can's CLI reads it: true/false, a number, else text."""
    key, sep, raw = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"must be KEY=VALUE, got {text!r}")
    value: Any = raw
    if raw.lower() in {"true", "false"}:
        value = raw.lower() == "true"
    else:
        for kind in (int, float):
            try:
                value = kind(raw)
                break
            except ValueError:
                continue
    return key, value


def add_bus_options(
    parser: argparse.ArgumentParser,
    *,
    default_interface: str | None = "socketcand",
    interface_help: str = "python-can interface: socketcand (the simulator, default), socketcan,"
    " pcan, …",
) -> None:
    """Add the shared bus options to a sub-command's parser (`default_interface` None: no bus
    unless `-i` is given)."""
    group = parser.add_argument_group("CAN bus (as python-can's and cantools' tools take it)")
    group.add_argument(
        "-i",
        "--interface",
        default=default_interface,
        choices=sorted(can.VALID_INTERFACES),
        metavar="NAME",
        help=interface_help,
    )
    group.add_argument("-c", "--channel", default="can0", help="CAN channel (default: can0)")
    group.add_argument(
        "--bus-kwargs",
        nargs="+",
        type=_keyword,
        default=[],
        metavar="KEY=VALUE",
        help="more python-can bus arguments, e.g. --bus-kwargs fd=true data_bitrate=2000000",
    )
    group.add_argument(
        "--host", default=DEFAULT_HOST, help=f"socketcand host (default: {DEFAULT_HOST})"
    )
    group.add_argument(
        "--port", type=int, default=DEFAULT_PORT, help=f"socketcand port (default: {DEFAULT_PORT})"
    )
    group.add_argument(
        "--bitrate",
        type=int,
        metavar="BPS",
        help="bitrate, for adapters that set it (default: the adapter's own)",
    )


def bus_from_args(args: argparse.Namespace, **options: Any) -> can.BusABC:
    """Open the bus the options name (`options`: e.g. can_filters); HardwareError otherwise."""
    options = {**options, **dict(args.bus_kwargs)}
    if args.bitrate is not None and args.interface != "socketcand":
        options.setdefault("bitrate", args.bitrate)
    return open_bus(args.interface, args.channel, args.host, args.port, **options)


def bus_source(args: argparse.Namespace) -> str:
    """How the bus is shown to the user: 'socketcand can0 @ 127.0.0.1:29536'."""
    source = f"{args.interface} {args.channel}"
    if args.interface == "socketcand":
        source += f" @ {args.host}:{args.port}"
    return source
