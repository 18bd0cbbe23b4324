"""`bywire rc`: the RC calibration view, live (textual) or as one snapshot, and the suggestion.

The source follows the robot file, as `bywire run` does: a `backend = "linux"` file's `rc.port`,
or `--port` for any other device; a `backend = "sim"` file, or no file (the simulator's
defaults), gets the simulated transmitter swept through every stick and switch (`--sim` forces
it). The suggestion (`bywire.rc.suggestion`) is printed to stdout at the end and written to
`--write-suggestion FILE`; the robot file is never edited.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bywire.cli.arguments import add_snapshot_options, number_within, snapshot_s
from bywire.cli.console import stdout_console
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.errors import ConfigError
from bywire.hal.opening import LinuxPaths
from bywire.rc.ibus_reading import RcSession
from bywire.rc.snippet import snippet_text
from bywire.rc.sources import ByteSource, SerialSource
from bywire.rc.suggestion import MIN_TRAVEL_RAW, Suggestion
from bywire.rc.sweep import SWEEP_S, SweepSource
from bywire.rc.view import snapshot_table, status

SNAPSHOT_S = 1.0
POLL_S = 0.05
DEFAULT_TRAVEL_PERCENT = 100.0

EPILOG = f"""\
What ArduPilot's radio calibration gives its users, for the robot file's [rc] section. For each
of the 14 IBUS channels it shows the pulse now, the lowest and highest seen, what the controller
reads in it with the robot file's calibration (steering -1..1, throttle or brake, the mode
switch's STOP / RC / CAN, or "between positions: STOP"; the gear; the lights) and where it
rested; above, the frames and every error counter (a frame with a bad checksum is counted and
dropped, as the controller does); below, the suggested calibration as TOML.

Calibrate: move each stick to both ends and let it spring back (hold a stick that does not
centre at its middle a moment); move each switch through every position, holding each a moment.
A stick gets min_raw/center_raw/max_raw once it went at least {MIN_TRAVEL_RAW} us either way from
its centre; a switch gets positions_raw (the pulse it rests at in each position), band_raw and
hysteresis_raw once it rested at exactly as many places as it has positions. What is not ready
is named with the reason. Paste the tables over the robot file's own and run
`bywire config check FILE`: this command never edits the robot file.

Source: a robot file with backend = "linux" is read from its rc.port (stop the bywire service
first: the port is opened exclusively), --port reads another device; otherwise (no --config, a
backend = "sim" file, or --sim) a simulated transmitter is swept through every stick and switch
(one sweep: {SWEEP_S:.1f} s), with its travel set by --sim-travel.

Live: q or Ctrl-C quits and prints the suggestion; r starts over (forgets ranges and rests).
--once and --duration print one table and the suggestion instead (the simulated transmitter
then runs in virtual time, as fast as it can). Exit 0, or 1 when no frame arrived.

examples:
  bywire rc --config /etc/bywire/robot.toml                   # the robot's receiver, live
  bywire rc --config robot.toml --port /dev/ttyUSB0 --write-suggestion rc.toml
  bywire rc --sim --sim-travel 50 --config robot.toml --duration 12   # a 50 % transmitter
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="robot configuration TOML: its [rc] mapping and calibration, and its rc.port when"
        " its backend is linux (default: the simulator defaults)",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--port", metavar="DEV", help="read this serial device (115200 8N1) instead of rc.port"
    )
    source.add_argument(
        "--sim", action="store_true", help="the simulated transmitter, whatever the robot file"
    )
    parser.add_argument(
        "--sim-travel",
        type=number_within(30.0, 140.0),
        metavar="PERCENT",
        help=f"the simulated transmitter's stick and switch travel, 30..140 %%"
        f" (default {DEFAULT_TRAVEL_PERCENT:g})",
    )
    add_snapshot_options(parser, SNAPSHOT_S, "the table and the suggestion")
    parser.add_argument(
        "--write-suggestion",
        type=Path,
        metavar="FILE",
        help="also write the suggestion (TOML) to FILE at the end (kept if it exists)",
    )
    parser.add_argument(
        "--force", action="store_true", help="let --write-suggestion overwrite its FILE"
    )


def run(args: argparse.Namespace) -> int:
    config = default_sim_config() if args.config is None else load_config(args.config)
    origin = "the simulator defaults" if args.config is None else str(args.config)
    if args.write_suggestion is not None:
        _check_writable(args.write_suggestion, force=args.force)
    listen_s = snapshot_s(args, SNAPSHOT_S)
    source = _source(args, config, paced=listen_s is None)
    session = RcSession(config)
    code = 0
    try:
        if listen_s is None:
            _live(source, session, config, origin)
        else:
            code = _snapshot(source, session, listen_s)
    finally:
        source.close()
    text = snippet_text(
        config, session.suggestion(), origin=origin, seen_on=_seen_on(source, session)
    )
    sys.stdout.write(text)
    if args.write_suggestion is not None:
        _write(args.write_suggestion, text)
    return code


def _source(args: argparse.Namespace, config: RobotConfig, *, paced: bool) -> ByteSource:
    simulated = args.sim or (args.port is None and config.backend == "sim")
    if not simulated:
        if args.sim_travel is not None:
            raise ConfigError("--sim-travel goes with the simulated transmitter (--sim)")
        return SerialSource(LinuxPaths().device(args.port or config.rc.port), config.rc.baud)
    travel = (DEFAULT_TRAVEL_PERCENT if args.sim_travel is None else args.sim_travel) / 100.0
    return SweepSource(config.rc.mapping, travel, paced=paced)


def _live(source: ByteSource, session: RcSession, config: RobotConfig, origin: str) -> None:
    from bywire.rc.app import RcApp  # noqa: PLC0415 -- textual: live view only

    def snippet(suggestion: Suggestion) -> str:
        return snippet_text(config, suggestion, origin=origin, seen_on=_seen_on(source, session))

    RcApp(source, session, snippet).run()


def _snapshot(source: ByteSource, session: RcSession, duration_s: float) -> int:
    """Listen `duration_s` on the source's clock (Ctrl-C ends it early), print the table."""
    interrupted = False
    end_s = source.now() + duration_s
    try:
        while (left_s := end_s - source.now()) > 0:
            source.wait(min(POLL_S, left_s))
            session.feed(source.read(), source.now())
    except KeyboardInterrupt:
        interrupted = True
    title = status(session, source.name, source.problem, source.now())
    stdout_console().print(snapshot_table(session, session.suggestion(), title), soft_wrap=True)
    if session.last_frame_s is None:
        print(
            f"bywire rc: no IBUS frame from {source.name} in {duration_s:g} s: is the receiver"
            " bound, its output set to i-BUS, and wired to this port?",
            file=sys.stderr,
        )
    if interrupted:
        return 130
    return 0 if session.last_frame_s is not None else 1


def _seen_on(source: ByteSource, session: RcSession) -> str:
    return f"{source.name} in {session.seen.frames} frames"


def _check_writable(path: Path, *, force: bool) -> None:
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")
    if path.exists() and not force:
        raise ConfigError(f"{path} exists: add --force to overwrite it, or choose another file")


def _write(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as error:
        raise ConfigError(f"cannot write {path}: {error.strerror or error}") from error
    print(f"bywire rc: suggestion written to {path}", file=sys.stderr)
