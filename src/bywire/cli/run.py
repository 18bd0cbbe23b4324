"""`bywire run --config FILE`: the controller on the robot's hardware until a stop signal.

Opens the hardware from the configuration (`bywire.hal.opening`) and runs the control loop, which
tells systemd READY=1, WATCHDOG=1 and STOPPING=1 through `hal.linux.systemd.notify`. SIGINT,
SIGTERM and SIGHUP (the terminal closed, an SSH session dropped) end the loop at its next wake-up,
and a second one while it stops changes nothing; whatever ends the run (a signal, a device error, a
bug), the runtime writes the safe outputs and the hardware's exit de-energises them. Device
problems are one line and exit 2.

Nothing the controller's thread does waits on the terminal: log lines go out through a thread of
their own (`background_log`), so a terminal that stops reading never delays a stop. With a
`[telemetry]` section (or `--mcap`) the telemetry feed records to MCAP and serves Foxglove, and
the CAN port is wrapped where it is built so that every frame the controller sends and receives
is on the feed. `--dashboard` starts `bywire dashboard --attach` as a child process on that feed
(`bywire.dashboard.child`): the view shares no thread, lock or interpreter with the controller.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import logging
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

from bywire.cli import background_log
from bywire.config import RobotConfig, load_config
from bywire.config.security_setup import configured_key, controller_receiver
from bywire.errors import BywireError, HardwareError
from bywire.hal.linux.device_errors import reason
from bywire.hal.linux.systemd import notify
from bywire.hal.opening import LinuxPaths, open_hardware, preflight
from bywire.loopback import DEFAULT_HOST, Endpoint, ListenAddress, parse_listen_address
from bywire.runtime.loop import Runtime
from bywire.runtime.realtime import RealtimeReport, apply_collector, apply_process
from bywire.runtime.settings import RuntimeConfig
from bywire.security.session import SecocReceiver
from bywire.telemetry.can_tap import TappedCanPort
from bywire.telemetry.feed import (
    FeedOptions,
    FeedSinks,
    check_mcap_path,
    new_outbox,
    open_sinks,
)

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)  # SIGHUP: the terminal closed
LOG_FORMAT = "bywire run: %(levelname)s %(name)s: %(message)s"
LOG_DRAIN_S = 0.3  # at the end, how long the log lines may take to reach the terminal
FEED_CLOSE_S = 0.3  # at the end, how long the writer may take to encode what is queued
ANY_ADDRESS_VIEW = {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}
log = logging.getLogger(__name__)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config", type=Path, required=True, metavar="FILE", help="robot configuration TOML"
    )
    parser.add_argument(
        "--sysfs-root",
        type=Path,
        default=LinuxPaths().sysfs_root,
        metavar="DIR",
        help="where sysfs is mounted (containers, tests; default: /sys)",
    )
    parser.add_argument(
        "--dev-root",
        type=Path,
        default=LinuxPaths().dev_root,
        metavar="DIR",
        help="where device names such as i2c-1 and gpiochip0 resolve (default: /dev)",
    )
    parser.add_argument("--verbose", action="store_true", help="log device events in detail")
    parser.add_argument(
        "--check",
        action="store_true",
        help="pre-flight: open every device the configuration names, one at a time, report each"
        " (all problems at once), close it again, and exit (0: all ready, 2: a problem); the"
        " outputs are never energised",
    )
    parser.add_argument(
        "--dashboard",
        action="store_true",
        help="show the live controller view in this terminal (mode, speed, flags, commands, "
        "actuators, inputs, task table) from a child process attached to the telemetry feed; "
        "q, SIGINT or SIGTERM stop the controller with safe outputs; a view that hangs or is "
        "killed changes nothing in the controller; log lines are printed when it ends",
    )
    parser.add_argument(
        "--mcap",
        type=Path,
        metavar="FILE.mcap",
        help="record the telemetry feed (state, events, CAN frames) to this MCAP file (instead"
        " of [telemetry] mcap)",
    )


def run(args: argparse.Namespace) -> int:
    if args.dashboard and not sys.stderr.isatty():  # where the view draws
        raise BywireError("--dashboard needs a terminal (stderr is not one)")
    level = logging.DEBUG if args.verbose else logging.INFO
    logs = background_log.install(LOG_FORMAT, level, sys.stderr.fileno())
    try:
        return _run(args, logs)
    finally:
        logs.resume()
        logs.drain(LOG_DRAIN_S)  # a terminal that does not read does not hold the exit


def _run(args: argparse.Namespace, logs: background_log.BackgroundLog) -> int:
    robot = load_config(args.config)
    paths = LinuxPaths(args.sysfs_root, args.dev_root)
    if args.check:
        return _preflight(robot, paths)
    options = feed_options(robot, mcap=args.mcap, dashboard=args.dashboard)
    # Before the hardware opens: its reader threads and the watchdog inherit scheduler and CPUs.
    realtime = apply_process(robot.realtime, python=sys.executable)
    # The stop signals are ours until the hardware is closed: a second SIGINT or SIGTERM while
    # the safe outputs are written only asks again, it never cuts the shutdown short.
    requests = _StopRequests()
    secoc = _authentication(robot, args.config)
    # The feed and the view end after the hardware is closed (the stack is left last).
    with (
        _stop_on_signals(requests),
        contextlib.ExitStack() as after_hardware,
        _device_errors(),
        open_hardware(robot, paths) as opened,
    ):
        hardware, sinks = opened, None
        if options is not None:
            outbox = new_outbox(options, virtual_time=False)
            hardware = dataclasses.replace(opened, can=TappedCanPort(opened.can, outbox))
            # The server, the file and the view start before the controller is built: the
            # loop's first deadlines are counted from then, and must not wait for them.
            sinks = after_hardware.enter_context(
                open_sinks(
                    options,
                    opened.clock,
                    virtual_time=False,
                    outbox=outbox,
                    close_timeout_s=FEED_CLOSE_S,
                )
            )
            _announce(options, sinks)
            if args.dashboard:
                _start_view(after_hardware, requests, view_url(options, sinks), logs)
        runtime = Runtime(hardware, RuntimeConfig.from_robot(robot), notify=notify, secoc=secoc)
        _report_authentication(robot, secoc)
        requests.runtime = runtime
        realtime.extend(apply_collector(robot.realtime, runtime).report)
        _report_realtime(realtime)
        _start_schedule_now(runtime)
        if options is not None and sinks is not None:
            sinks.tap(runtime, rate_hz=options.rate_hz).attach()
        if requests.signals:  # one came while the hardware opened: stop before driving
            runtime.request_stop()
        log.info("running %s (%s backend)", robot.name, robot.backend)  # signals handled
        _report_estop(robot)
        runtime.run()
    log.info("stopped; outputs de-energised")
    return 0


def _start_schedule_now(runtime: Runtime) -> None:
    """Count the schedule from now, not from when the runtime was built: the start-up work in
    between (the collector's freeze, the log lines) is no deadline the loop missed, and left
    as it was it made the first pass look 5-20 ms late (the "start stall")."""
    now = runtime.clock.now()
    runtime.started_at = now
    for task in runtime.tasks:
        task.first_deadline_s = task.next_deadline_s = now


def feed_options(robot: RobotConfig, *, mcap: Path | None, dashboard: bool) -> FeedOptions | None:
    """The feed the configuration and the options ask for (None: no feed at all).

    `--mcap` takes the place of `[telemetry] mcap`; `--dashboard` needs a server, on a free
    loopback port unless `[telemetry] foxglove` names one.
    """
    section = robot.telemetry
    mcap_path = mcap if mcap is not None else None if section.mcap is None else Path(section.mcap)
    if mcap_path is not None:
        check_mcap_path(mcap_path)
    foxglove: Endpoint | ListenAddress | None = None
    if section.foxglove is not None:
        foxglove = parse_listen_address(section.foxglove, allow_remote=section.allow_remote)
    if foxglove is None and dashboard:
        foxglove = Endpoint(DEFAULT_HOST, 0)
    options = FeedOptions(mcap_path, foxglove, section.rate_hz, origins=section.allowed_origins)
    return options if options.wanted else None


def view_url(options: FeedOptions, feed: FeedSinks) -> str:
    """Where a view on this machine reaches the feed's server."""
    assert options.foxglove is not None
    host = ANY_ADDRESS_VIEW.get(options.foxglove.host, options.foxglove.host)
    return f"ws://[{host}]:{feed.port}" if ":" in host else f"ws://{host}:{feed.port}"


def _announce(options: FeedOptions, feed: FeedSinks) -> None:
    if options.mcap_path is not None:
        log.info("recording telemetry to %s", options.mcap_path)
    if options.foxglove is not None:
        host = options.foxglove.host
        url_host = f"[{host}]" if ":" in host else host
        log.info("serving telemetry to Foxglove on ws://%s:%s", url_host, feed.port)


def _start_view(
    stack: contextlib.ExitStack,
    requests: _StopRequests,
    url: str,
    logs: background_log.BackgroundLog,
) -> None:
    """The dashboard as a child process on the feed; log lines wait until it has gone."""
    from bywire.dashboard.child import ViewProcess  # noqa: PLC0415 -- only with --dashboard

    view = ViewProcess(
        url,
        on_quit=requests.quit,
        write_raw=logs.write_raw,
        terminal_fd=sys.stderr.fileno(),
    )
    logs.hold()
    stack.callback(logs.resume)
    stack.callback(view.stop)
    view.start()


def _authentication(robot: RobotConfig, config_path: Path) -> SecocReceiver | None:
    """The verifier of authenticated commands ([security] enabled), None when off; its key is
    read and its trip counter moved on (on the disk) before any device opens."""
    security = robot.security
    if not security.enabled:
        return None
    return controller_receiver(security, configured_key(security), str(config_path))


def _report_authentication(robot: RobotConfig, receiver: SecocReceiver | None) -> None:
    """One line when authentication is on (the key by its check value only)."""
    if receiver is not None:
        log.info(
            "authentication: on (SecOC profile 3, key check value %s, trip counter %d, %s)",
            receiver.key_check_value,
            receiver.trip,
            robot.security.freshness_file or "in memory",
        )


def _report_estop(robot: RobotConfig) -> None:
    """Whether an E-stop is read: a warning when the file of a real robot does not say (the
    simulator has its button whatever the file says)."""
    if robot.estop.stated or robot.backend == "sim":
        log.info("%s", robot.estop.summary())
    else:
        log.warning("%s", robot.estop.summary())


def _preflight(robot: RobotConfig, paths: LinuxPaths) -> int:
    """Each device on a line: ready, or its problem and what to do; 2 if any is not ready."""
    with _device_errors():
        results = preflight(robot, paths)
    for name, problem in results:
        print(f"ready    {name}" if problem is None else f"PROBLEM  {name}: {problem}")
    failed = sum(problem is not None for _, problem in results)
    print(f"{robot.name}: {len(results) - failed} of {len(results)} devices ready")
    print(robot.estop.summary())
    return 2 if failed else 0


def _report_realtime(report: RealtimeReport) -> None:
    """A warning naming the fix for each refused setting, then the one-line summary."""
    for refusal in report.refused:
        log.warning("%s", refusal)
    log.info("%s", report.line())


class _StopRequests:
    """The stop signals received, and the runtime they stop once there is one."""

    def __init__(self) -> None:
        self.signals: list[int] = []
        self.runtime: Runtime | None = None

    def __call__(self, signal_number: int, _frame: FrameType | None) -> None:
        self.signals.append(signal_number)
        if self.runtime is not None:
            self.runtime.request_stop()

    def quit(self) -> None:
        """The operator quit the view (its thread): stop as on a signal."""
        self(0, None)


@contextlib.contextmanager
def _stop_on_signals(requests: _StopRequests) -> Iterator[None]:
    """The stop signals go to `requests` while the block runs; after it (the hardware closed,
    the process ending) they are ignored: a late one must not turn a clean exit into a
    traceback or a kill. Only `bywire run`, which ends the process, uses this."""
    for number in STOP_SIGNALS:
        signal.signal(number, requests)
    try:
        yield
    finally:
        for number in STOP_SIGNALS:
            signal.signal(number, signal.SIG_IGN)


@contextlib.contextmanager
def _device_errors() -> Iterator[None]:
    """An OSError that no backend put into words still becomes one line, not a traceback."""
    try:
        yield
    except HardwareError:
        raise
    except OSError as error:
        where = f" ({error.filename})" if error.filename else ""
        raise HardwareError(f"device error{where}: {reason(error)}") from error
