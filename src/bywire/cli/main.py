"""The `bywire` entry point: one sub-command per module in bywire.cli, loaded on demand."""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import sys
from collections.abc import Callable, Sequence
from typing import NoReturn, Protocol

from bywire import __version__
from bywire.background import OWNER
from bywire.build import build_name
from bywire.errors import BywireError

# name -> (module, one-line help). Modules are imported only when their command runs, so that
# `bywire --help` stays fast and one broken optional dependency cannot take down every command.
COMMANDS: dict[str, tuple[str, str]] = {
    "sim": (
        "bywire.cli.sim",
        "run the controller on the simulated robot through a scenario, then summarise",
    ),
    "demo": ("bywire.cli.demo", "run the codecs on simulated traffic and show what they do"),
    "bittiming": (
        "bywire.cli.bittiming",
        "CAN bit timing: bxCAN CAN_BTR values and ip-link settings",
    ),
    "dbc": ("bywire.cli.dbc", "the CAN database: show messages and signals, generate C code"),
    "verify": (
        "bywire.cli.verify",
        "random fault campaigns on your robot configuration, checked against docs/SAFETY.md",
    ),
    "bench": ("bywire.cli.bench", "measure latency, jitter, CPU, memory and speed-up (§8)"),
    "run": ("bywire.cli.run", "run the controller on the robot's hardware (until SIGINT/SIGTERM)"),
    "config": ("bywire.cli.config", "robot configuration: check a file, print what it resolves to"),
    "keys": ("bywire.cli.keys", "keys for authenticated commands (SecOC): make a new key file"),
    "replay": (
        "bywire.cli.replay",
        "run the controller again on a recorded run's inputs and compare its outputs",
    ),
    "plot": ("bywire.cli.plot", "PNG of a CAN log (BLF, ASC, TRC, MF4, CSV, candump) with a DBC"),
    "monitor": (
        "bywire.cli.monitor",
        "live view of the CAN bus decoded with the DBC: rates, ages, signals, CRC/counter errors",
    ),
    "frame": (
        "bywire.cli.frame",
        "print valid command frames (counter, CRC, MAC) for cansend",
    ),
    "teleop": (
        "bywire.cli.teleop",
        "drive the robot or the simulator from the keyboard; shows its reports",
    ),
    "ros2": (
        "bywire.cli.ros2",
        "the higher-level computer's ROS 2 node: cmd_vel in, odom and diagnostics out",
    ),
    "rc": (
        "bywire.cli.rc",
        "RC calibration: live IBUS channels, how the robot reads them, the [rc] values to paste",
    ),
    "dashboard": (
        "bywire.cli.dashboard",
        "live view of the controller on the simulated robot: mode, outputs, flags, task table",
    ),
}


class _Parser(argparse.ArgumentParser):
    """argparse, with the nearest option suggested for a misspelt one (`--scenaro`)."""

    suggest_from: argparse.ArgumentParser | None = None
    """The selected sub-command's parser: its options are what a user most likely meant."""

    def error(self, message: str) -> NoReturn:
        prefix = "unrecognized arguments: "
        if message.startswith(prefix) and self.suggest_from is not None:
            message += _suggestion(message.removeprefix(prefix).split(), self.suggest_from)
            self.suggest_from.error(message)  # with the sub-command's usage
        super().error(message)


def _suggestion(given: list[str], parser: argparse.ArgumentParser) -> str:
    """' (did you mean --scenario?)' for the first unknown option close to a known one."""
    known = _options(parser)
    for word in given:
        if word.startswith("--"):
            close = difflib.get_close_matches(word.split("=", 1)[0], known, n=1)
            if close:
                return f" (did you mean {close[0]}?)"
    return ""


def _options(parser: argparse.ArgumentParser) -> list[str]:
    """Every option string of `parser` and of its sub-commands' parsers (`dbc show --dbc`)."""
    found: list[str] = []
    for action in parser._actions:  # argparse keeps them nowhere public
        found += action.option_strings
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found += _options(sub)
    return found


class CommandModule(Protocol):
    """What a module in bywire.cli provides for its sub-command."""

    def configure(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...


def _load(name: str) -> CommandModule:
    module: CommandModule = importlib.import_module(COMMANDS[name][0])
    return module


def build_parser(selected: str | None) -> argparse.ArgumentParser:
    """The parser; only the selected sub-command's module is imported to add its options."""
    parser = _Parser(
        prog="bywire",
        description="Low-level drive-by-wire controller: CAN and FlySky IBUS in, actuators out.",
    )
    version = f"bywire {__version__} ({build_name()})"  # pure, or compiled (mypyc X): issue 43
    parser.add_argument("--version", action="version", version=version)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_module, help_text) in COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        if name == selected:
            _load(name).configure(command_parser)
            parser.suggest_from = command_parser
    return parser


def _selected_command(argv: Sequence[str]) -> str | None:
    return next((arg for arg in argv if arg in COMMANDS), None)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one sub-command; bywire's own errors become one line on stderr and exit status 2."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    selected = _selected_command(arguments)
    parser = build_parser(selected)
    args = parser.parse_args(arguments)
    if args.command is None:
        parser.print_help()
        return 2
    runner: Callable[[argparse.Namespace], int] = _load(args.command).run
    try:
        with OWNER.scope():  # every thread and child the command started ends with it
            return runner(args)
    except BywireError as error:
        print(f"bywire {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # The reader went away (`bywire … | head`): not an error; keep Python quiet at exit.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
