"""`bywire teleop`: drive the robot (or the simulator) from the keyboard over any python-can bus."""

from __future__ import annotations

import argparse
import logging
import socket
from typing import Any

import can

from bywire.errors import HardwareError
from bywire.protocol import dbc
from bywire.teleop.state import HOLD_S, KEYS

DEFAULT_PORT = 29536
STANDARD_ID_MASK = 0x7FF
CONNECT_TIMEOUT_S = 2.0

EPILOG = f"""\
keys:
{chr(10).join(f"  {binding.key:<7} {binding.label}" for binding in KEYS)}
  q       quit (one period of full brake, then the commands stop: the robot times out to STOP)

Holding a key auto-repeats it. With no up/down key for {HOLD_S} s the throttle ramps down to 0;
with no left/right key for {HOLD_S} s the steering returns to the centre. Gear changes drop the
throttle to 0. The robot enters CAN mode only with zero throttle, after its RC transmitter's mode
switch went through STOP; after a remote stop, release it (s) and re-enable (e).

examples:
  # the simulator, started in another terminal by `bywire sim --realtime --serve {DEFAULT_PORT}`
  bywire teleop
  # the robot's bus
  bywire teleop --interface socketcan --channel can0
"""


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the bus options and the key table."""
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument(
        "--interface",
        default="socketcand",
        help="python-can interface: socketcand (the simulator, default), socketcan, virtual, …",
    )
    parser.add_argument("--channel", default="can0", help="CAN channel (default can0)")
    parser.add_argument("--host", default="127.0.0.1", help="socketcand host (default 127.0.0.1)")
    parser.add_argument(
        "--port", type=int, default=DEFAULT_PORT, help=f"socketcand port (default {DEFAULT_PORT})"
    )
    parser.add_argument(
        "--bitrate", type=int, default=500_000, help="bitrate for adapters that set it (500000)"
    )


def open_bus(args: argparse.Namespace) -> can.BusABC:
    """The bus, filtered to the robot's reports; HardwareError with what to do when it fails."""
    if args.interface not in can.VALID_INTERFACES:
        known = ", ".join(sorted(can.VALID_INTERFACES))
        raise HardwareError(f"unknown python-can interface {args.interface!r} (known: {known})")
    options: dict[str, Any] = {"bitrate": args.bitrate}
    if args.interface == "socketcand":
        _check_listening(args)
        options = {"host": args.host, "port": args.port}
    filters: list[Any] = [
        {"can_id": frame_id, "can_mask": STANDARD_ID_MASK, "extended": False}
        for frame_id in dbc.report_ids()
    ]
    logging.getLogger("can").setLevel(logging.ERROR)
    try:
        return can.Bus(
            interface=args.interface, channel=args.channel, can_filters=filters, **options
        )
    except Exception as error:  # drivers raise anything, even NameError
        raise HardwareError(_open_hint(args, error)) from error


def _check_listening(args: argparse.Namespace) -> None:
    """Fail at once when nothing listens: python-can's socketcand retries for 10 s, silently."""
    try:
        socket.create_connection((args.host, args.port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as error:
        raise HardwareError(_open_hint(args, error)) from error


def _open_hint(args: argparse.Namespace, error: Exception) -> str:
    reason = " ".join(str(error).split()) or type(error).__name__
    if args.interface == "socketcand":
        return (
            f"CAN socketcand {args.host}:{args.port} ({args.channel}): cannot connect: {reason}:"
            f" start the simulator with `bywire sim --realtime --serve {args.port}`"
        )
    return f"CAN {args.interface} {args.channel}: cannot open: {reason}"


def run(args: argparse.Namespace) -> int:
    """Open the bus and run the terminal program until `q`."""
    bus = open_bus(args)
    try:
        run_app(bus)
    finally:
        bus.shutdown()
    return 0


def run_app(bus: can.BusABC) -> None:
    """The textual program on ``bus`` (imported here: textual is only needed by this command)."""
    from bywire.teleop.app import TeleopApp  # noqa: PLC0415 -- keeps `bywire --help` fast

    TeleopApp(bus).run()
