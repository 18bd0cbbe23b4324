"""`bywire teleop`: drive the robot (or the simulator) from the keyboard or a gamepad over any
python-can bus."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import can

from bywire.cli.bus_options import add_bus_options, bus_from_args
from bywire.errors import HardwareError
from bywire.protocol import dbc
from bywire.security.keys import read_key_file
from bywire.security.session import TRIP_IDS, SecocSigner
from bywire.security.setup import sender_signer
from bywire.teleop.state import HOLD_S, KEYS

if TYPE_CHECKING:
    from bywire.teleop.app import PadInput
    from bywire.teleop.gamepad_device import GamepadDriver

DEFAULT_PORT = 29536
AUTO = "auto"
STANDARD_ID_MASK = 0x7FF

EPILOG = f"""\
keys:
{chr(10).join(f"  {binding.key:<7} {binding.label}" for binding in KEYS)}
  q       quit, as Ctrl-C does (one period of full brake, then the commands stop: the robot
          times out to STOP)

Holding a key auto-repeats it. With no up/down key for {HOLD_S} s the throttle ramps down to 0;
with no left/right key for {HOLD_S} s the steering returns to the centre. Gear changes drop the
throttle to 0. The robot enters CAN mode only with zero throttle, after its RC transmitter's mode
switch went through STOP; after a remote stop, release it (s) and re-enable (e).

gamepad (--gamepad [DEVICE], Linux, evdev: pip install 'bywire[gamepad]'):
{{GAMEPAD}}
Hold the dead man to drive: released, throttle 0 and full brake at once, steering centred. If
the trigger is pulled when the dead man is pressed, the throttle stays 0 until it is let go.
Without DEVICE the first gamepad in /dev/input is used; reading it needs the group 'input'.

examples:
  # the simulator, started in another terminal by `bywire sim --realtime --serve {DEFAULT_PORT}`
  bywire teleop
  # the robot's bus
  bywire teleop -i socketcan -c can0
  # a PEAK adapter at 500 kbit/s
  bywire teleop -i pcan -c PCAN_USBBUS1 --bitrate 500000
  # a gamepad on the simulator; or name it: --gamepad /dev/input/by-id/usb-…-event-joystick
  bywire teleop --gamepad
  # a robot with authenticated commands ([security] enabled): the same key file as the robot's
  bywire teleop -i socketcan -c can0 --key ~/.config/bywire/secoc.key
"""
DEFAULT_FRESHNESS = Path.home() / ".local" / "state" / "bywire" / "teleop-freshness.json"

# The gamepad's mapping, written out here so that `--help` needs no evdev; a test holds it to
# bywire.teleop.gamepad.help_lines().
GAMEPAD_HELP = """\
  LB (hold)      dead man: held = drive, released = throttle 0, full brake
  left stick     steering
  right trigger  throttle
  left trigger   brake
  Y              forward
  A              reverse
  X              neutral
  B              remote stop
  START          re-enable
  d-pad left     turn left
  d-pad right    turn right
  d-pad up       low beam
  d-pad down     hazard"""


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the bus options and the key table."""
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG.replace("{GAMEPAD}", GAMEPAD_HELP)
    add_bus_options(parser)
    parser.add_argument(
        "--gamepad",
        nargs="?",
        const=AUTO,
        metavar="DEVICE",
        help="drive with a gamepad (Linux evdev device, e.g. /dev/input/event5; default: the"
        " first gamepad found); the keyboard's other keys still work",
    )
    parser.add_argument(
        "--key",
        type=Path,
        metavar="FILE",
        help="sign every command (SecOC, for a robot with [security] enabled) with this key"
        " file (mode 0600; bywire keys new FILE)",
    )
    parser.add_argument(
        "--freshness",
        type=Path,
        metavar="FILE",
        default=DEFAULT_FRESHNESS,
        help="with --key: where this sender keeps its freshness values across restarts"
        " (default: %(default)s)",
    )


def open_bus(args: argparse.Namespace) -> can.BusABC:
    """The bus, filtered to the robot's reports (and, signing, its trip counter announcement);
    HardwareError with what to do when it fails."""
    wanted = (*dbc.report_ids(), *(sorted(TRIP_IDS) if args.key is not None else ()))
    filters: list[Any] = [
        {"can_id": frame_id, "can_mask": STANDARD_ID_MASK, "extended": False} for frame_id in wanted
    ]
    logging.getLogger("can").setLevel(logging.ERROR)
    return bus_from_args(args, can_filters=filters)


def run(args: argparse.Namespace) -> int:
    """Open the gamepad (if asked) and the bus, and run the terminal program until `q`."""
    gamepad = None
    if args.gamepad is not None:
        gamepad = _open_gamepad(None if args.gamepad == AUTO else Path(args.gamepad))
    signer = None
    try:
        signer = None if args.key is None else _signer(args.key, args.freshness)
        bus = open_bus(args)
        try:
            run_app(bus, gamepad, signer)
        finally:
            bus.shutdown()
    finally:
        if gamepad is not None:
            gamepad.close()
        if signer is not None:
            signer.close()
    return 0


def _open_gamepad(path: Path | None) -> GamepadDriver:
    """The gamepad's driver; evdev (Linux only, optional) is imported only here."""
    try:
        from bywire.teleop.gamepad_device import open_driver  # noqa: PLC0415 -- see above
    except ModuleNotFoundError as error:
        if error.name != "evdev":
            raise
        raise HardwareError(
            "--gamepad needs the evdev package (Linux only), which is not installed:"
            " pip install 'bywire[gamepad]'"
        ) from None
    return open_driver(path)


def _signer(key_file: Path, freshness: Path) -> SecocSigner:
    key = read_key_file(key_file)
    freshness.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    return sender_signer(key, freshness)


def run_app(
    bus: can.BusABC, gamepad: PadInput | None = None, signer: SecocSigner | None = None
) -> None:
    """The textual program on ``bus`` (imported here: textual is only needed by this command)."""
    from bywire.teleop.app import TeleopApp  # noqa: PLC0415 -- keeps `bywire --help` fast

    TeleopApp(bus, gamepad=gamepad, signer=signer).run()
