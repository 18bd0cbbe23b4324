"""`bywire frame`: command frames the controller accepts, printed for `cansend` (can-utils).

A hand-written frame cannot pass the controller's checks (counter, CRC-8 and, on a robot with
authenticated commands, the SecOC MAC); this prints valid ones, one `ID#HEXDATA` a line:
`--count N` consecutive frames (the counter going up by one a frame, as the controller wants),
each followed by its cryptographic PDU when `--key` is given, in the trip counter the robot
announces (`--trip`). Encoded by the same codec the controller decodes with (`protocol.dbc`)
and signed by the same signer as `bywire teleop`.
"""

from __future__ import annotations

import argparse
import enum
import typing
from collections.abc import Iterator
from pathlib import Path

from bywire.cli.arguments import number_within, whole_number
from bywire.command_table import COMMANDS, CommandSpec
from bywire.config.security_setup import sender_signer
from bywire.errors import ConfigError
from bywire.model import (
    Command,
    ControlCommand,
    Gear,
    LightsCommand,
    MovementCommand,
    command_fields,
    with_counter,
)
from bywire.protocol import dbc
from bywire.protocol.secoc import MAX_TRIP
from bywire.security.freshness import Adoption
from bywire.security.keys import read_key_file
from bywire.security.session import SecocSigner

DEFAULT_FRESHNESS = Path.home() / ".local" / "state" / "bywire" / "frame-freshness.json"
EXAMPLES = """examples:
  cansend vcan0 $(bywire frame control --re-enable)       # leave a latched STOP (CAN mode)
  bywire frame movement --throttle 0.2 --gear forward --count 100 |
    while read -r f; do cansend vcan0 "$f"; sleep 0.02; done  # 2 s of driving at 50 Hz
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EXAMPLES
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    kinds = parser.add_subparsers(dest="message", metavar="MESSAGE", required=True)
    for spec in COMMANDS:  # one subcommand per command row, named by its slot
        sub = kinds.add_parser(spec.slot, help=f"{spec.name} (0x{dbc.frame_id(spec.kind):03X})")
        _OPTIONS.get(spec.slot, _field_options)(sub, spec)
        _common(sub)


def _movement_options(movement: argparse.ArgumentParser, _spec: CommandSpec) -> None:
    unit = number_within(0.0, 1.0)
    movement.add_argument(
        "--steering", type=number_within(-1.0, 1.0), default=0.0, help="-1 (left) … 1 (right)"
    )
    movement.add_argument("--throttle", type=unit, default=0.0, help="0 … 1")
    movement.add_argument("--brake", type=unit, default=0.0, help="0 … 1")
    movement.add_argument("--gear", choices=[gear.name.lower() for gear in Gear], default="neutral")


def _lights_options(lights: argparse.ArgumentParser, _spec: CommandSpec) -> None:
    for name in ("turn-left", "turn-right", "hazard", "low-beam"):
        lights.add_argument(f"--{name}", action="store_true")


def _control_options(control: argparse.ArgumentParser, _spec: CommandSpec) -> None:
    control.add_argument("--remote-stop", action="store_true", help="stop the robot (latched)")
    control.add_argument(
        "--re-enable", action="store_true", help="a re-enable request (acts on its rising edge)"
    )


def _field_options(parser: argparse.ArgumentParser, spec: CommandSpec) -> None:
    """A row without options of its own: one per field of its message (`--name`), a flag for a
    truth value, a member's name for an enum, a number otherwise (the codec checks its range)."""
    hints = typing.get_type_hints(spec.kind)
    for field in command_fields(spec.kind):
        if field.name == "counter":
            continue
        option, kind = f"--{field.name.replace('_', '-')}", hints[field.name]
        default = getattr(spec.neutral, field.name)
        if kind is bool:
            parser.add_argument(option, action="store_true")
        elif isinstance(kind, type) and issubclass(kind, enum.Enum):
            names = [member.name.lower() for member in kind]
            parser.add_argument(option, choices=names, default=default.name.lower())
        else:
            parser.add_argument(option, type=kind, default=default)


_OPTIONS = {"movement": _movement_options, "lights": _lights_options, "control": _control_options}
"""The rows whose options say more than their fields (ranges, help): by slot."""


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--counter", type=_counter, default=0, help="the first frame's rolling counter, 0…15"
    )
    parser.add_argument(
        "--count", type=whole_number(1), default=1, help="frames to print, counter +1 each"
    )
    parser.add_argument(
        "--key",
        type=Path,
        metavar="FILE",
        help="sign each frame (SecOC) for a robot with [security] enabled: its key file",
    )
    parser.add_argument(
        "--trip",
        type=_trip,
        metavar="N",
        help="with --key: the trip counter the robot announces (TripCounter 0x206's trip_counter:"
        " `bywire monitor` shows it); frames of any other trip are refused by the robot",
    )
    parser.add_argument(
        "--freshness",
        type=Path,
        metavar="FILE",
        default=DEFAULT_FRESHNESS,
        help="with --key: this sender's freshness values (default: %(default)s)",
    )


def _counter(text: str) -> int:
    value = whole_number(0)(text)
    if value >= dbc.COUNTER_MODULUS:
        raise argparse.ArgumentTypeError(f"must be 0…{dbc.COUNTER_MODULUS - 1}, got {text!r}")
    return value


def _trip(text: str) -> int:
    value = whole_number(1)(text)
    if value > MAX_TRIP:
        raise argparse.ArgumentTypeError(f"must be 1…{MAX_TRIP}, got {text!r}")
    return value


def command_of(args: argparse.Namespace) -> Command:
    """The command the options describe, with the first counter."""
    if args.message == "movement":
        gear = Gear[args.gear.upper()]
        return MovementCommand(args.steering, args.throttle, args.brake, gear, args.counter)
    if args.message == "lights":
        return LightsCommand(
            args.turn_left, args.turn_right, args.hazard, args.low_beam, args.counter
        )
    if args.message == "control":
        return ControlCommand(args.remote_stop, args.re_enable, args.counter)
    spec = next(spec for spec in COMMANDS if spec.slot == args.message)
    hints = typing.get_type_hints(spec.kind)
    values = {
        field.name: _value(hints[field.name], getattr(args, field.name))
        for field in command_fields(spec.kind)
        if field.name != "counter"
    }
    values["counter"] = args.counter
    return spec.kind(**values)


def _value(kind: object, given: object) -> object:
    if isinstance(kind, type) and issubclass(kind, enum.Enum) and isinstance(given, str):
        return kind[given.upper()]
    return given


def frames(command: Command, count: int) -> Iterator[tuple[int, bytes]]:
    """`count` frames of `command`, the counter going up by one a frame (modulo 16)."""
    for index in range(count):
        counter = (command.counter + index) % dbc.COUNTER_MODULUS
        yield dbc.encode_command(with_counter(command, counter))


def cansend(frame_id: int, data: bytes) -> str:
    """`ID#HEXDATA`, as can-utils' cansend takes a classic frame."""
    return f"{frame_id:03X}#{data.hex().upper()}"


def run(args: argparse.Namespace) -> int:
    command = command_of(args)
    if (args.key is None) != (args.trip is None):
        raise ConfigError(
            "--key and --trip go together: a signed frame carries the robot's trip counter"
            " (TripCounter 0x206's trip_counter: `bywire monitor` shows it)"
        )
    signer = None if args.key is None else _signer(args.key, args.freshness, args.trip)
    try:
        for frame_id, data in frames(command, args.count):
            pdu = None if signer is None else signer.authenticator(frame_id, data)
            if signer is not None and pdu is None:
                raise ConfigError(f"{args.freshness}: cannot reserve a freshness value")
            print(cansend(frame_id, data))
            if pdu is not None:
                print(cansend(pdu.arbitration_id, pdu.data))
    finally:
        if signer is not None:
            signer.close()
    return 0


def _signer(key_file: Path, freshness: Path, trip: int) -> SecocSigner:
    """A signer in `trip`; ConfigError when this sender already signed in a later trip."""
    freshness.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    signer = sender_signer(read_key_file(key_file), freshness)
    try:
        adoption = signer.take_trip(trip)
    except OSError as error:
        signer.close()
        raise ConfigError(f"{freshness}: cannot write: {error.strerror or error}") from None
    if adoption is Adoption.LOWER:
        signer.close()
        raise ConfigError(
            f"--trip {trip}: this sender signed in trip {signer.store.trip} already"
            f" ({freshness}); give the trip the robot announces now"
        )
    return signer
