"""`bywire sim`: the real controller on the simulated robot, driven by a scenario, then a summary.

By default it plays `test-course`, the thesis' trial run (§5.1.2), in virtual time. It shows
progress on stderr while it runs (when stderr is a terminal), prints the summary, optionally
writes a plot and a CAN log, and exits 1 when an expectation of the scenario failed.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from types import FrameType, ModuleType

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from bywire.canlog.write import BusTally, CanLog, check_log_path
from bywire.cli.arguments import positive_hertz, positive_seconds
from bywire.cli.bus_options import add_bus_options, bus_from_args, bus_source
from bywire.cli.console import stdout_console
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.config.sections import ORIGIN
from bywire.errors import ConfigError
from bywire.hal.simulated.clock import RealtimeClock
from bywire.loopback import Endpoint, parse_endpoint
from bywire.netbus.bridge import serve_bus
from bywire.netbus.interface import on_interface
from bywire.replay.recorder import SimRunRecorder, check_record_path
from bywire.sim.applicability import not_applicable
from bywire.sim.catalog import DEFAULT_SCENARIO, find_scenario, packaged_scenarios
from bywire.sim.estop_key import estop_key as keys_for_estop
from bywire.sim.plot import check_plot_path, write_plot
from bywire.sim.runner import SimRun, run_clock
from bywire.sim.suite import Case, collect, junit_xml, run_case
from bywire.sim.summary import build_summary, render
from bywire.telemetry.capture import DEFAULT_RATE_HZ, Capture, PoseCapture
from bywire.telemetry.feed import FeedOptions, FeedSinks, check_mcap_path, open_sinks
from bywire.telemetry.outbox import Outbox

PROGRESS_PERIOD_S = 0.1  # simulated seconds between progress updates
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
INTERRUPTED = 130  # the shell's status for a run ended by Ctrl-C


MAX_SPEED = 1000.0  # far past what the simulator keeps up with in real time; virtual time is faster


def positive_speed(text: str) -> float:
    """--speed N: a number above 0 and at most MAX_SPEED."""
    try:
        speed = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 < speed <= MAX_SPEED:
        raise argparse.ArgumentTypeError(f"must be above 0 and at most {MAX_SPEED:g}, got {text}")
    return speed


def _endpoint(text: str) -> Endpoint:
    try:
        return parse_endpoint(text)
    except ConfigError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _origin(text: str) -> str:
    if not ORIGIN.fullmatch(text):
        raise argparse.ArgumentTypeError(
            f"{text!r}: not an origin such as https://app.foxglove.dev"
        )
    return text


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        metavar="NAME|FILE",
        help=f"packaged scenario (see --list) or scenario TOML file (default: {DEFAULT_SCENARIO})",
    )
    parser.add_argument("--list", action="store_true", help="list the packaged scenarios and exit")
    parser.add_argument(
        "--all",
        nargs="?",
        const="",
        metavar="DIR",
        help="run every packaged scenario (or every *.toml in DIR) and give a verdict for each;"
        " exit 1 if any failed",
    )
    parser.add_argument(
        "--junit",
        type=Path,
        metavar="FILE.xml",
        help="with --all: write a JUnit XML report for CI systems",
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        metavar="S",
        help="simulated seconds (default: the scenario's)",
    )
    parser.add_argument(
        "--realtime", action="store_true", help="pace the run by the wall clock (live view)"
    )
    parser.add_argument(
        "--speed",
        type=positive_speed,
        metavar="N",
        help="pace the run by the wall clock at N times real time (SITL's --speed: watch a run"
        " in Foxglove at 5x); --speed 1 is --realtime",
    )
    parser.add_argument(
        "--json", action="store_true", help="print the summary as JSON and nothing else"
    )
    parser.add_argument("--plot", type=Path, metavar="FILE.png", help="write a plot of the run")
    parser.add_argument(
        "--log",
        type=Path,
        metavar="FILE.blf|.asc|.log|.trc|.csv|.mf4",
        help="write every CAN frame (BLF, Vector ASC, candump -L, PEAK TRC, python-can CSV or"
        " ASAM MDF4 with asammdf, by suffix)",
    )
    parser.add_argument(
        "--rosbag",
        type=Path,
        metavar="DIR",
        help="write a rosbag2 (MCAP) of the bus to this new folder: every frame, the decoded"
        " reports, odometry and diagnostics, for ros2 bag and Foxglove (needs bywire[ros])",
    )
    parser.add_argument(
        "--record",
        type=Path,
        metavar="FILE.jsonl",
        help="write a run record (every input and output of the controller) for bywire replay",
    )
    parser.add_argument(
        "--serve",
        type=_endpoint,
        metavar="[HOST:]PORT",
        help="with --realtime: serve the simulated bus to socketcand clients (python-can,"
        " cantools, bywire monitor) on this loopback port (host 127.0.0.1, ::1 or localhost)",
    )
    parser.add_argument(
        "--mcap",
        type=Path,
        metavar="FILE.mcap",
        help="record the telemetry feed (state, events, CAN frames) to an MCAP file for"
        " Foxglove, PlotJuggler or the mcap tools; log times are the run's clock",
    )
    parser.add_argument(
        "--foxglove",
        type=_endpoint,
        metavar="[HOST:]PORT",
        help="with --realtime: serve the telemetry feed to Foxglove (WebSocket) on this loopback"
        " port (host 127.0.0.1, ::1 or localhost; port 0: any free port)",
    )
    parser.add_argument(
        "--foxglove-origin",
        action="append",
        default=[],
        type=_origin,
        metavar="ORIGIN",
        help="with --foxglove: a web page origin the server lets in (repeatable), e.g."
        " https://app.foxglove.dev; by default no web page is (a browser tab of any site could"
        " read the feed), only clients that send no Origin (the desktop app, bywire dashboard)",
    )
    parser.add_argument(
        "--telemetry-rate",
        type=positive_hertz,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help=f"state messages per second of the feed (default: {DEFAULT_RATE_HZ:g})",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="overwrite the files of --plot, --log, --record and --mcap if they exist"
        " (refused otherwise)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="robot configuration TOML (default: the packaged simulator defaults)",
    )
    parser.add_argument(
        "--authenticated",
        action="store_true",
        help="SecOC-authenticated commands: the simulated computer signs, the controller"
        " verifies (as [security] enabled = true: its key file; without one, a key drawn from the"
        " simulator's seed)",
    )
    add_bus_options(
        parser,
        default_interface=None,
        interface_help="with --realtime: put the simulated robot's CAN side on this python-can"
        " interface (socketcan with -c vcan0 or can0, a USB adapter's …): candump, cansend and"
        " other tools see and drive it; the rest stays simulated",
    )


def run(args: argparse.Namespace) -> int:
    if args.list:
        _list(as_json=args.json)
        return 0
    if args.all is not None:
        return _run_all(args)
    _check_one_run(args)
    robot = _robot(args)
    scenario = find_scenario(args.scenario)
    clock = run_clock(scenario, realtime=args.realtime, speed=args.speed)
    realtime = isinstance(clock, RealtimeClock)
    if args.serve is not None and not realtime:
        raise ConfigError("--serve needs --realtime: virtual time outruns any client")
    if args.foxglove is not None and not realtime:
        raise ConfigError("--foxglove needs --realtime: virtual time outruns any client")
    feed = FeedOptions(
        args.mcap, args.foxglove, args.telemetry_rate, origins=tuple(args.foxglove_origin)
    )
    stopped_by: list[int] = []
    with contextlib.ExitStack() as sinks_open:
        # The feed's writer (on real time a process of its own: ~0.2 s to start, seconds on a
        # busy machine) is running before the robot's clock starts: the controller's first pass
        # and the scenario's first events are on time, not late by the writer's start.
        sinks = None
        if feed.wanted:
            sinks = sinks_open.enter_context(open_sinks(feed, clock, virtual_time=not realtime))
        sim = SimRun(robot, scenario, duration_s=args.duration, clock=clock)
        # A signal after the run's end (while the plot is drawn) is noted, never an interruption.
        with _stop_on_signals(sim, stopped_by), _on_interface(args, sim):
            status = _one_run(args, sim, stopped_by, sinks)
    return INTERRUPTED if stopped_by else status


def _one_run(
    args: argparse.Namespace, sim: SimRun, stopped_by: list[int], sinks: FeedSinks | None
) -> int:
    """Play `sim`, write its files, print its summary; 1 if an expectation failed."""
    recorder = None if args.record is None else SimRunRecorder.attach(sim, args.record)
    tally = BusTally()
    sim.add_can_monitor(tally)
    feed = (
        None
        if sinks is None
        else (sinks, FeedOptions(args.mcap, args.foxglove, args.telemetry_rate))
    )
    wall_s, frames_logged, log_failure = _play(
        sim,
        args.log,
        show_progress=sys.stderr.isatty() and not args.json,
        serve=args.serve,
        feed=feed,
        rosbag=args.rosbag,
        estop_key=_keys_for_estop(args, sim),
    )
    # A file that cannot be written whole is one line of its own; the run, the summary and the
    # other files go on (exit 1: what was asked for is not all there).
    failures = [] if log_failure is None else [log_failure]
    if recorder is not None:
        failures += _written(recorder.write)
    summary = build_summary(sim, wall_s, tally)
    aside = not_applicable(sim.scenario, sim.robot)
    if args.plot is not None:
        failures += _written(lambda: write_plot(sim, args.plot))
    files = {"plot": _name(args.plot), "can_log": _name(args.log)}
    files.update({} if recorder is None else {"record": str(recorder.path)})
    files.update({} if args.mcap is None else {"mcap": str(args.mcap)})
    files.update({} if args.rosbag is None else {"rosbag": str(args.rosbag)})
    if args.json:
        document = {
            **summary.as_json(),
            "not_applicable": aside,
            "files": files,
            "file_errors": failures,
        }
        print(json.dumps(document, indent=2))
    else:
        console = stdout_console()
        render(summary, console)
        for line in _file_lines(args, frames_logged):
            console.print(line, soft_wrap=True)
        if stopped_by:
            name = signal.Signals(stopped_by[0]).name
            console.print(f"Stopped by {name} after {summary.simulated_s:.1f} s", soft_wrap=True)
        if aside is not None:
            console.print(f"[yellow]{sim.scenario.name}: {escape(aside)}[/]", soft_wrap=True)
    for failure in failures:
        print(f"bywire sim: error: {failure}", file=sys.stderr, flush=True)
    # A scenario that does not apply to the robot is no verdict on it (as `--all` sets it aside).
    return 0 if (summary.passed or aside is not None) and not failures else 1


def _written(write: Callable[[], object]) -> list[str]:
    """Write one of the run's files; its failure as a line, or nothing."""
    try:
        write()
    except ConfigError as error:
        return [str(error)]
    return []


@contextlib.contextmanager
def _on_interface(args: argparse.Namespace, sim: SimRun) -> Iterator[None]:
    """The simulated bus on `-i`/`-c`'s interface for the run (real time only), or nothing."""
    if args.interface is None:
        yield
        return
    if not isinstance(sim.world.clock, RealtimeClock):
        raise ConfigError("-i/--interface needs --realtime: virtual time outruns a real bus")
    with on_interface(sim.world.bus, bus_from_args(args)):
        print(f"the simulated bus is on {bus_source(args)}", file=sys.stderr, flush=True)
        yield


@contextlib.contextmanager
def _stop_on_signals(sim: SimRun, received: list[int]) -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP end the run at the loop's next pass, as its end would: the
    outputs are made safe, the log and the recording are closed complete, and the summary and
    the plot are written for the part that ran. (From the main thread only: Python delivers
    signals there; a run in another thread keeps the default handlers.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(number: int, _frame: FrameType | None) -> None:
        received.append(number)
        sim.runtime.request_stop()

    previous = {number: signal.signal(number, stop) for number in STOP_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _file_lines(args: argparse.Namespace, frames_logged: int) -> list[str]:
    """A line for each file the run wrote."""
    lines = []
    if args.plot is not None:
        lines.append(f"Plot: {args.plot}")
    if args.log is not None:
        lines.append(f"CAN log: {args.log} ({frames_logged} frames)")
    if args.record is not None:
        lines.append(f"Run record: {args.record} (for bywire replay)")
    if args.mcap is not None:
        lines.append(f"MCAP: {args.mcap} (open it in Foxglove)")
    if args.rosbag is not None:
        lines.append(f"rosbag2: {args.rosbag} (ros2 bag info {args.rosbag})")
    return lines


def _robot(args: argparse.Namespace) -> RobotConfig:
    robot = default_sim_config() if args.config is None else load_config(args.config)
    if args.authenticated:
        return replace(robot, security=replace(robot.security, enabled=True))
    return robot


def _check_one_run(args: argparse.Namespace) -> None:
    """Refuse what cannot work before the run starts, not after it."""
    if args.junit is not None:
        raise ConfigError("--junit needs --all: the report is of several scenarios")
    if args.speed is not None and args.realtime and args.speed != 1.0:
        raise ConfigError(
            f"--realtime is --speed 1: give one of --realtime, --speed {args.speed:g}"
        )
    if args.plot is not None:
        check_plot_path(args.plot)
    if args.log is not None:
        check_log_path(args.log)
    if args.mcap is not None:
        check_mcap_path(args.mcap)
    if args.rosbag is not None:
        rosbag_module().check_bag_path(args.rosbag)
    if args.record is not None:
        check_record_path(args.record)
    for option in OUTPUT_FILES:
        path = getattr(args, option)
        if path is not None and path.exists() and not args.force:
            raise ConfigError(
                f"--{option} {path}: the file exists: add --force to overwrite it, or choose"
                " another file"
            )


OUTPUT_FILES = ("plot", "log", "record", "mcap")
"""The options that name a file the run writes: an existing one is kept unless --force."""


def _name(path: Path | None) -> str | None:
    return None if path is None else str(path)


def _keys_for_estop(args: argparse.Namespace, sim: SimRun) -> bool:
    """The E-stop on the `e` key: a live run (`--realtime`) at a terminal, on a robot that wires
    an E-stop."""
    live = isinstance(sim.world.clock, RealtimeClock) and not args.json
    return live and sys.stdin.isatty() and sim.world.hardware.estop_line is not None


def _play(
    sim: SimRun,
    log_path: Path | None,
    *,
    show_progress: bool,
    serve: Endpoint | None = None,
    feed: tuple[FeedSinks, FeedOptions] | None = None,
    rosbag: Path | None = None,
    estop_key: bool = False,
) -> tuple[float, int, str | None]:
    """Run to the end; (wall seconds, frames logged, why the log stopped early if it did). The
    log is closed even if the run fails."""
    with contextlib.ExitStack() as stack:
        log = None
        if log_path is not None:
            log = stack.enter_context(CanLog(log_path, sim.started_at))
            sim.add_can_monitor(log)
        if rosbag is not None:
            bag = rosbag_module().RosbagExport(rosbag, sim.started_at, time.time(), sim.robot)
            sim.add_can_monitor(stack.enter_context(bag))
        if serve is not None:
            _serve(stack, sim, serve)
        if feed is not None:
            attach_feed(stack, sim, *feed)
        if show_progress:
            stack.enter_context(_progress(sim))
        if estop_key:
            print("press e to press or release the E-stop", file=sys.stderr, flush=True)
            stack.enter_context(keys_for_estop(sim.world.estop, sys.stdin, _say))
        started = time.perf_counter()
        sim.run()
        wall_s = time.perf_counter() - started
    if log is None:
        return wall_s, 0, None
    return wall_s, log.frames, log.failure


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _serve(stack: contextlib.ExitStack, sim: SimRun, endpoint: Endpoint) -> None:
    """Put the bus on the network for the run; where it listens goes to stderr (port 0: any)."""
    bridge = stack.enter_context(serve_bus(sim.world.bus, endpoint, sim.started_at))
    host, port = bridge.server.address
    print(
        f"serving the simulated bus on {host} port {port} (socketcand, channel"
        f" {bridge.server.channel})",
        file=sys.stderr,
        flush=True,
    )


def attach_feed(
    stack: contextlib.ExitStack, sim: SimRun, sinks: FeedSinks, options: FeedOptions
) -> None:
    """The telemetry feed's tap for the run, its sinks already open (`open_sinks`), with every
    frame on the bus and the vehicle's pose, as `--mcap` and `--foxglove` attach it
    (bench/differential.py too); the port goes to stderr."""
    tap = sinks.tap(sim.runtime, rate_hz=options.rate_hz).attach()
    stack.callback(tap.detach)
    sim.add_can_monitor(
        lambda frame: tap.can_frame(frame.time_s, frame.arbitration_id, frame.data, frame.sender)
    )
    sim.runtime.on_cycle.append(_pose_sampler(sim, sinks.outbox, options.rate_hz))
    if options.foxglove is not None:
        host = options.foxglove.host
        url_host = f"[{host}]" if ":" in host else host
        print(
            f"serving telemetry to Foxglove on ws://{url_host}:{sinks.port}",
            file=sys.stderr,
            flush=True,
        )


def _pose_sampler(sim: SimRun, outbox: Outbox[Capture], rate_hz: float) -> Callable[[float], None]:
    """After the loop's passes, at the feed's rate: where the simulated vehicle is (the 3D
    panel's path). A plain tuple of four numbers, queued as the tap queues its captures."""
    period_s = 1.0 / rate_hz
    due = [sim.started_at]

    def sample(now: float) -> None:
        if now >= due[0]:
            state = sim.world.vehicle.state
            outbox.put(PoseCapture(now, state.x_m, state.y_m, state.heading_rad))
            due[0] = now + period_s

    return sample


@contextlib.contextmanager
def _progress(sim: SimRun) -> Iterator[None]:
    """A progress bar on stderr in simulated seconds, with the speed-up and the robot's state."""
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:5.1f}/{task.total:.1f} s"),
        TimeElapsedColumn(),
        TextColumn("{task.fields[live]}"),
        console=Console(stderr=True),
        transient=True,
    )
    wall_start_s = time.perf_counter()

    def update(elapsed_s: float) -> None:
        speedup = elapsed_s / max(time.perf_counter() - wall_start_s, 1e-9)
        live = f"×{speedup:.1f}"
        now = sim.record.samples.last
        if now is not None:
            live += f"  {now.mode.name:<4} {now.speed_mps:5.2f} m/s {now.distance_m:6.1f} m"
        progress.update(task, completed=min(elapsed_s, sim.duration_s), live=live)

    with progress:
        task = progress.add_task(sim.scenario.name, total=sim.duration_s, live="")
        sim.every(PROGRESS_PERIOD_S, update)
        yield
        update(sim.duration_s)


def _list(*, as_json: bool) -> None:
    scenarios = packaged_scenarios()
    if as_json:
        rows = [
            {"name": name, "duration_s": s.duration_s, "description": s.description}
            for name, s in scenarios.items()
        ]
        print(json.dumps(rows, indent=2))
        return
    table = Table("scenario", "duration", "description", box=None, pad_edge=False)
    for name, scenario in scenarios.items():
        table.add_row(name, f"{scenario.duration_s:g} s", scenario.description)
    stdout_console().print(table)


def rosbag_module() -> ModuleType:
    """bywire.ros2.bag, whose rosbags is optional: one line saying how to get it otherwise."""
    try:
        return importlib.import_module("bywire.ros2.bag")
    except ModuleNotFoundError as error:
        if error.name is None or not error.name.startswith("rosbags"):
            raise
        raise ConfigError("--rosbag needs rosbags: pip install 'bywire[ros]'") from None


ONE_RUN_OPTIONS = (
    "duration",
    "realtime",
    "speed",
    *OUTPUT_FILES,
    "force",
    "serve",
    "foxglove",
    "rosbag",
)


def _run_all(args: argparse.Namespace) -> int:
    """Every scenario, one verdict line each (or JSON), the JUnit report; 1 if any failed."""
    given = [f"--{name}" for name in ONE_RUN_OPTIONS if getattr(args, name)]
    if given:
        raise ConfigError(f"{', '.join(given)}: for one scenario; --all runs each as written")
    robot = _robot(args)
    found = collect(Path(args.all) if args.all else None)
    console = stdout_console()
    cases = []
    for name, origin, load in found:
        case = run_case(robot, name, origin, load)
        cases.append(case)
        if not args.json:
            _print_case(console, case)
    if args.junit is not None:
        try:
            args.junit.write_text(junit_xml(cases), encoding="utf-8")
        except OSError as error:
            raise ConfigError(f"cannot write {args.junit}: {error.strerror or error}") from None
    failed = [case.name for case in cases if case.failed]
    set_aside = [case.name for case in cases if case.not_applicable is not None]
    if args.json:
        rows = [
            {
                "name": case.name,
                "origin": case.origin,
                "passed": case.passed,
                "applicable": case.not_applicable is None,
                "reasons": case.reasons if case.not_applicable is None else [case.not_applicable],
                "wall_s": round(case.wall_s, 3),
            }
            for case in cases
        ]
        document = {"scenarios": rows, "failed": failed, "not_applicable": set_aside}
        print(json.dumps(document, indent=2))
    else:
        colour = "red" if failed else "green"
        applicable = len(cases) - len(set_aside)
        aside = f" ({len(set_aside)} not applicable to this robot)" if set_aside else ""
        console.print(
            f"[bold {colour}]{applicable - len(failed)} of {applicable} scenarios passed[/]{aside}"
            + (f"; JUnit report: {args.junit}" if args.junit is not None else ""),
            soft_wrap=True,
        )
    return 1 if failed else 0


def _print_case(console: Console, case: Case) -> None:
    """One verdict line (PASS, FAIL or N/A), and each reason indented below it."""
    if case.not_applicable is not None:
        console.print(f"[yellow]N/A [/] {case.name}", highlight=False)
        reasons = [case.not_applicable]
    else:
        verdict = "[green]PASS[/]" if case.passed else "[red]FAIL[/]"
        console.print(f"{verdict} {case.name} ({case.wall_s:.1f} s)", highlight=False)
        reasons = case.reasons
    for reason in reasons:
        console.print(f"     {escape(reason)}", highlight=False, soft_wrap=True)
