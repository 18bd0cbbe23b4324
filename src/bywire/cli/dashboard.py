"""`bywire dashboard`: the live view of a controller, as a client of its telemetry feed."""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from bywire.background import OWNER
from bywire.cli.arguments import positive_seconds
from bywire.config import load_config
from bywire.errors import ConfigError, HardwareError
from bywire.sim.catalog import DEFAULT_SCENARIO, find_scenario

if TYPE_CHECKING:
    from bywire.dashboard.client import FeedClient

EPILOG = """\
The view is a client of the controller's telemetry feed (Foxglove's WebSocket protocol), in a
process of its own: it never slows the controller, and closing it changes nothing there. It
shows the mode and latch, the speed, error flags by name, the movement set-point and its source,
the actuator outputs, input ages and counts, and the task table (the counterpart of the thesis'
Figure 30): measured rate, runtime share, worst start jitter, overruns and budget overruns, and
the idle share. It fits an 80x24 terminal. When the feed ends the last picture stays on screen.
q or Ctrl-C quits.

With --attach it watches a running controller: `bywire run` with [telemetry] foxglove set (or
--dashboard), or `bywire sim --realtime --foxglove PORT`. Without it, it starts the simulated
robot on a scenario (as `bywire sim --realtime --foxglove`) and watches that; q stops it.

examples:
  bywire dashboard                          # the test course (40 s) on the simulated robot
  bywire dashboard --scenario rc-link-lost  # watch RC_LOST latch STOP
  bywire dashboard --attach 8765            # a controller serving its feed on 127.0.0.1:8765
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument(
        "--attach",
        metavar="[HOST:]PORT|ws://…",
        help="watch the telemetry feed served there (default host 127.0.0.1)",
    )
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        metavar="NAME|FILE",
        help=f"without --attach: packaged scenario or a file (default {DEFAULT_SCENARIO})",
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        metavar="S",
        help="without --attach: seconds to run (default: the scenario's)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="without --attach: robot configuration TOML (default: the simulator defaults)",
    )


def attach_url(text: str) -> str:
    """ws://… as given, or [HOST:]PORT as ws://HOST:PORT (host 127.0.0.1 when left out)."""
    if text.startswith(("ws://", "wss://")):
        return text
    host, separator, port_text = text.rpartition(":")
    if not port_text.isdigit() or not 0 < int(port_text) <= 65535:
        raise ConfigError(f"--attach: expected [HOST:]PORT or ws://HOST:PORT, got {text!r}")
    host = host.strip("[]") if separator and host else "127.0.0.1"
    return f"ws://[{host}]:{port_text}" if ":" in host else f"ws://{host}:{port_text}"


def run(args: argparse.Namespace) -> int:
    """Watch the feed until q (and, without --attach, stop the simulated robot after)."""
    if args.attach is not None:
        given = [f"--{name}" for name in ("duration", "config") if getattr(args, name)]
        if args.scenario != DEFAULT_SCENARIO:
            given.append("--scenario")
        if given:
            raise ConfigError(f"{', '.join(given)}: for the simulated robot, not with --attach")
        _step_aside()
        with _Ending() as ending:
            return show(attach_url(args.attach), source=args.attach, ending=ending, attach=True)
    from bywire.dashboard.child import SimFeed  # noqa: PLC0415

    find_scenario(args.scenario)  # a wrong name or file: one line here, not in the child
    arguments = ["--scenario", args.scenario]
    if args.duration is not None:
        arguments += ["--duration", repr(args.duration)]
    if args.config is not None:
        load_config(args.config)
        arguments += ["--config", str(args.config)]
    with _Ending() as ending:  # before the robot starts: a SIGTERM from now on stops it too
        sim = SimFeed(arguments, on_started=ending.robot_started)  # at this command's priority
        _step_aside()
        name = Path(args.scenario).stem
        try:
            status = show(sim.url, source=f"scenario {name}", ending=ending, verdict=sim.verdict)
        finally:
            sim.stop()
        # After the view, on the terminal it leaves: the expectations' verdict.
        print(f"scenario {name}: expectations {sim.verdict()}")
        return status


def show(
    url: str,
    *,
    source: str,
    ending: _Ending | None = None,
    attach: bool = False,
    verdict: Callable[[], str | None] | None = None,
) -> int:
    """The textual program on the feed at `url` (textual is imported only for this); with
    `ending`, a SIGTERM closes the feed's client before the view goes. With `attach`, a feed
    that is not there is an error before any view opens (HardwareError, exit 2), within the
    client's bounded wait, rather than a view that waits forever."""
    from bywire.dashboard.app import DashboardApp  # noqa: PLC0415 -- keeps `bywire --help` fast
    from bywire.dashboard.client import FeedClient  # noqa: PLC0415

    client = FeedClient(url).start()
    if ending is not None:
        ending.client = client
    try:
        failed = client.wait_live() if attach else None
        if failed is not None:
            raise HardwareError(
                f"--attach {source}: {failed}; is a controller serving its feed there"
                " (`bywire run` with [telemetry] foxglove, or `bywire sim --realtime --foxglove"
                " PORT`, which prints the port)?"
            )
        app = DashboardApp(client, source=source, verdict=verdict)
        app.run()
    finally:
        client.close()
    return app.return_code or 0


CLOSE_WAIT_S = 1.0  # on SIGTERM, the longest wait for the feed's closing handshake
ROBOT_STOP_S = 5.0  # …and for the simulated robot to stop safe (then it is killed)


class _Ending:
    """What a SIGTERM (a service manager, `bywire run --dashboard` ending) does to the view.

    It closes the feed's client with a handshake, so the server prints no "connection reset"
    into the terminal, and stops the simulated robot the view started (Ctrl-C: it stops safe),
    which would otherwise outlive it; then the view ends at once, as the default action would,
    with a signal's status, never 0 (which `bywire run` takes for the operator's stop). Whoever
    sent the signal restores the terminal.

    A signal handler runs between two bytecodes of the main thread, which may hold a lock the
    client or `subprocess` needs: the close runs in a thread of its own with a bounded wait, the
    robot is signalled and reaped by its pid (only while `subprocess` has not reaped it, so the
    pid is still its own), and a second SIGTERM is ignored. In effect inside `with`.
    """

    def __init__(self) -> None:
        self.client: FeedClient | None = None
        self.robot: subprocess.Popen[str] | None = None
        self._previous: signal.Handlers | Callable[[int, FrameType | None], object] | int | None
        self._previous = None

    def __enter__(self) -> _Ending:
        self._previous = signal.signal(signal.SIGTERM, self._terminated)
        return self

    def __exit__(self, *_exception: object) -> None:
        signal.signal(signal.SIGTERM, self._previous or signal.SIG_DFL)

    def robot_started(self, robot: subprocess.Popen[str]) -> None:
        self.robot = robot

    def _terminated(self, _signal: int, _frame: FrameType | None) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        client, robot = self.client, self.robot
        robot_pid = None if robot is None or robot.returncode is not None else robot.pid
        if robot_pid is not None:
            with contextlib.suppress(OSError):
                os.kill(robot_pid, signal.SIGINT)
        if client is not None:
            closing = OWNER.thread(client.close, name="bywire-dashboard-closing")
            closing.join(CLOSE_WAIT_S)
        if robot_pid is not None:
            _reap(robot_pid, ROBOT_STOP_S)
        os._exit(128 + signal.SIGTERM)


def _reap(pid: int, timeout_s: float) -> None:
    """Wait for child `pid` to end, without `subprocess` (whose lock the main thread may hold);
    kill it after `timeout_s`."""
    deadline_s = time.monotonic() + timeout_s
    with contextlib.suppress(ChildProcessError):
        while os.waitpid(pid, os.WNOHANG) == (0, 0):
            if time.monotonic() > deadline_s:
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                return
            time.sleep(0.02)


VIEW_NICENESS = 10  # a view yields the CPU to anything at normal priority (the controller)


def _step_aside() -> None:
    """The view is never more urgent than the controller it shows: it runs at a lower priority
    (nice 10), and, started by `bywire run` under SCHED_FIFO (only a controller sets it), it
    goes back to the normal scheduler and to the CPUs the controller does not use."""
    with contextlib.suppress(OSError, AttributeError):
        os.nice(VIEW_NICENESS)
    try:
        if os.sched_getscheduler(0) == os.SCHED_OTHER:
            return
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        others = set(range(os.cpu_count() or 1)) - os.sched_getaffinity(0)
        if others:
            os.sched_setaffinity(0, others)
    except (OSError, AttributeError):  # not Linux, or the kernel refused: the view runs as is
        return
