"""`bywire run --config FILE`: the controller on the robot's hardware until a stop signal.

Opens the hardware from the configuration (`bywire.hal.opening`) and runs the control loop, which
tells systemd READY=1, WATCHDOG=1 and STOPPING=1 through `hal.linux.systemd.notify`. SIGINT,
SIGTERM and SIGHUP (the terminal closed, an SSH session dropped) end the loop at its next wake-up,
and a second one while it stops changes nothing; whatever ends the run (a signal, a device error, a
bug), the runtime writes the safe outputs and the hardware's exit de-energises them. Device
problems are one line and exit 2.

With `--dashboard` the loop runs in a thread of its own and the terminal shows the live view of
`bywire dashboard` (see `bywire.dashboard.on_robot` for which thread owns what); q, SIGINT and
SIGTERM stop the controller, which writes the safe outputs before the hardware is closed.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

from bywire.config import RobotConfig, load_config
from bywire.errors import BywireError, HardwareError
from bywire.hal.linux.device_errors import reason
from bywire.hal.linux.systemd import notify
from bywire.hal.opening import LinuxPaths, open_hardware, preflight
from bywire.runtime.app import Runtime
from bywire.runtime.realtime import RealtimeReport, apply_collector, apply_process
from bywire.runtime.settings import RuntimeConfig
from bywire.security.session import SecocReceiver
from bywire.security.setup import configured_key, controller_receiver

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)  # SIGHUP: the terminal closed
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
        help="show the live controller view in this terminal (mode, flags, commands, actuators, "
        "inputs, task table); q, SIGINT or SIGTERM stop the controller with safe outputs; "
        "log lines are printed when it ends",
    )


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="bywire run: %(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    if args.dashboard and not sys.stderr.isatty():  # where textual draws
        raise BywireError("--dashboard needs a terminal (stderr is not one)")
    robot = load_config(args.config)
    paths = LinuxPaths(args.sysfs_root, args.dev_root)
    if args.check:
        return _preflight(robot, paths)
    status = 0
    # Before the hardware opens: its reader threads and the watchdog inherit scheduler and CPUs.
    realtime = apply_process(robot.realtime, python=sys.executable)
    # The stop signals are ours until the hardware is closed: a second SIGINT or SIGTERM while
    # the safe outputs are written only asks again, it never cuts the shutdown short.
    requests = _StopRequests()
    secoc = _authentication(robot)
    with (
        _closing(secoc),
        _stop_on_signals(requests),
        _device_errors(),
        open_hardware(robot, paths) as hardware,
    ):
        runtime = Runtime(hardware, RuntimeConfig.from_robot(robot), notify=notify, secoc=secoc)
        _report_authentication(robot, secoc)
        requests.runtime = runtime
        realtime.extend(apply_collector(robot.realtime, runtime).report)
        _report_realtime(realtime)
        if requests.signals:  # one came while the hardware opened: stop before driving
            runtime.request_stop()
        log.info("running %s (%s backend)", robot.name, robot.backend)  # signals handled
        if args.dashboard:
            status = _with_dashboard(runtime, f"{robot.name} ({robot.backend} backend)")
        else:
            runtime.run()
    log.info("stopped; outputs de-energised")
    return status


def _authentication(robot: RobotConfig) -> SecocReceiver | None:
    """The verifier of authenticated commands ([security] enabled), None when off; its key
    and freshness file are read before any device opens."""
    security = robot.security
    if not security.enabled:
        return None
    return controller_receiver(security, configured_key(security))


def _report_authentication(robot: RobotConfig, receiver: SecocReceiver | None) -> None:
    """One line when authentication is on (the key by its check value only)."""
    security = robot.security
    if receiver is None:
        return
    log.info(
        "authentication: on (SecOC profile 3, key check value %s, freshness %s)",
        receiver.key_check_value,
        security.freshness_file or "in memory",
    )
    if security.freshness_file is not None and not receiver.store.found:
        log.warning(
            "%s: no freshness for this key yet: starting at 0; if this key was used before,"
            " its old frames could be replayed: make a new key (docs/SECURITY.md)",
            security.freshness_file,
        )


@contextlib.contextmanager
def _closing(secoc: SecocReceiver | None) -> Iterator[None]:
    try:
        yield
    finally:
        if secoc is not None:
            secoc.close()


def _preflight(robot: RobotConfig, paths: LinuxPaths) -> int:
    """Each device on a line: ready, or its problem and what to do; 2 if any is not ready."""
    with _device_errors():
        results = preflight(robot, paths)
    for name, problem in results:
        print(f"ready    {name}" if problem is None else f"PROBLEM  {name}: {problem}")
    failed = sum(problem is not None for _, problem in results)
    print(f"{robot.name}: {len(results) - failed} of {len(results)} devices ready")
    return 2 if failed else 0


def _report_realtime(report: RealtimeReport) -> None:
    """A warning naming the fix for each refused setting, then the one-line summary."""
    for refusal in report.refused:
        log.warning("%s", refusal)
    log.info("%s", report.line())


def _with_dashboard(runtime: Runtime, source: str) -> int:
    """The controller in a thread, the view in front (textual is imported only for this)."""
    from bywire.dashboard.on_robot import run_with_dashboard  # noqa: PLC0415

    return run_with_dashboard(runtime, source=source)


class _StopRequests:
    """The stop signals received, and the runtime they stop once there is one."""

    def __init__(self) -> None:
        self.signals: list[int] = []
        self.runtime: Runtime | None = None

    def __call__(self, signal_number: int, _frame: FrameType | None) -> None:
        self.signals.append(signal_number)
        if self.runtime is not None:
            self.runtime.request_stop()


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
