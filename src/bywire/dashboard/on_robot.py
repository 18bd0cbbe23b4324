"""`bywire run --dashboard`: the controller on the robot in a thread of its own, the view in front.

Who owns what:

- The **controller thread** (`bywire-controller`) owns the `Runtime`: it runs `Runtime.run()`,
  whose `finally` writes the safe outputs, and it takes the dashboard's snapshots as an `on_cycle`
  observer, so nothing else ever reads the runtime's mutable state. The snapshot is wrapped in
  `GuardedObserver`: an exception in it is counted and shown ("snapshot failed"), it never ends
  the loop. The thread depends on nothing of the UI; it ends only on `request_stop` or an error.
- The **main thread** owns the hardware (opened before the controller starts, closed, and so
  de-energised, only after it has been joined), the SIGINT/SIGTERM handlers (Python runs them
  there; they only call `Runtime.request_stop`) and the terminal, where the textual app runs.
  The app reads immutable snapshots from the feed, and quits when the controller has ended.
- Every way out stops the controller and waits for it: `q` (the app's exit), a signal (the
  controller ends, the app sees it and quits), an error in the controller (the app quits, the
  error is raised again in the main thread), and a crash of the UI (`run_with_dashboard`'s
  `finally`). Log lines are held while the app owns the terminal and written afterwards.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import threading
from collections.abc import Callable, Iterator

from rich.text import Text
from textual.widgets import Static

from bywire.dashboard.app import DashboardApp
from bywire.dashboard.feed import SNAPSHOT_PERIOD_S, SnapshotFeed
from bywire.dashboard.view import mode_panel
from bywire.errors import BywireError
from bywire.runtime.app import Runtime

STOP_TIMEOUT_S = 5.0
HELD_LOG_RECORDS = 1000  # the newest ones, while the dashboard owns the terminal
log = logging.getLogger(__name__)


class GuardedObserver:
    """An `on_cycle` observer that can never end the loop: its exceptions are counted instead.

    After a failure the observer is left out for `retry_s` of controller time, so a snapshot that
    fails every time costs the loop one attempt per period, not one per pass. The first failure
    is logged with its traceback. `failure` (for the UI thread) says how often and the last error.
    """

    def __init__(
        self, observer: Callable[[float], None], *, retry_s: float = SNAPSHOT_PERIOD_S
    ) -> None:
        self._observer = observer
        self._retry_s = retry_s
        self._retry_at_s = float("-inf")
        self._lock = threading.Lock()
        self._failures = 0
        self._last_error = ""

    def __call__(self, now: float) -> None:
        if now >= self._retry_at_s:
            self.attempt(self._observer, now)

    def attempt(self, call: Callable[[float], None], now: float) -> None:
        """Call `call(now)` under the guard (from the controller thread)."""
        try:
            call(now)
        except Exception as error:  # any bug in the view: counted, shown, never the loop's end
            self._retry_at_s = now + self._retry_s
            with self._lock:
                self._failures += 1
                self._last_error = repr(error)
                first = self._failures == 1
            if first:
                log.exception("dashboard snapshot failed; the controller goes on")

    @property
    def failures(self) -> int:
        with self._lock:
            return self._failures

    @property
    def failure(self) -> str | None:
        """None while every snapshot succeeded; else 'snapshot failed …' for the screen."""
        with self._lock:
            if not self._failures:
                return None
            return f"snapshot failed ({self._failures}×, last {self._last_error})"


class RobotRun:
    """`runtime` played in the controller thread, observed through a guarded snapshot feed.

    `stop()` is safe from any thread and any number of times: it requests the stop and waits for
    the controller, whose `Runtime.run` has written the safe outputs by the time it returns.
    """

    def __init__(self, runtime: Runtime, feed: SnapshotFeed | None = None) -> None:
        self.runtime = runtime
        self.feed = feed or SnapshotFeed(runtime)
        self.guard = GuardedObserver(self.feed.observe)
        runtime.on_cycle.append(self.guard)  # not feed.attach(): only through the guard
        self.error: Exception | None = None
        self._thread = threading.Thread(target=self._control, name="bywire-controller", daemon=True)

    def start(self) -> RobotRun:
        self._thread.start()
        return self

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> bool:
        """Request the stop; True when the controller has ended (or never started)."""
        self.runtime.request_stop()
        if self._thread.is_alive():
            self._thread.join(timeout_s)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    @property
    def ended(self) -> bool:
        """The controller was started and has returned (stopped, or on an error)."""
        return self._thread.ident is not None and not self._thread.is_alive()

    def _control(self) -> None:
        status = "stopped: outputs safe"
        try:
            self.runtime.run()
        except Exception as error:  # raised again in the main thread by run_with_dashboard
            self.error = error
            status = f"controller stopped on an error: {error!r}; outputs safe"
        finally:
            # The last picture, with the safe outputs (the loop's observers no longer run).
            self.guard.attempt(lambda now: self.feed.observe(now, force=True), self._now())
            self.feed.finish(status)

    def _now(self) -> float:
        try:
            return self.runtime.clock.now()
        except Exception:  # a broken clock must not hide how the run ended
            return float("-inf")


class RobotDashboardApp(DashboardApp):
    """The dashboard of a `RobotRun`: says when snapshots fail, quits when the controller ends."""

    def __init__(self, robot: RobotRun, *, source: str = "") -> None:
        super().__init__(robot.feed, source=source, on_exit=robot.stop)
        self.robot = robot
        self._robot_source = source

    def refresh_view(self) -> None:
        super().refresh_view()
        failure = self.robot.guard.failure
        if failure is not None:
            status = self.feed.status
            parts = [self._robot_source, status, failure]
            self.sub_title = " · ".join(part for part in parts if part)
            snap = self.feed.latest()
            lines = "; ".join(part for part in (status, failure) if part)
            panel = Text(failure, style="bold red") if snap is None else mode_panel(snap, lines)
            self.query_one("#mode", Static).update(panel)
        if self.robot.ended:
            self.exit()


class _HoldRecords(logging.Handler):
    """Keeps the newest records while the app owns the terminal (any thread may log)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: collections.deque[logging.LogRecord] = collections.deque(
            maxlen=HELD_LOG_RECORDS
        )

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@contextlib.contextmanager
def held_logs() -> Iterator[None]:
    """Route the root logger's records into a buffer, then through its own handlers again."""
    root = logging.getLogger()
    handlers = root.handlers[:]
    hold = _HoldRecords()
    root.handlers = [hold]
    try:
        yield
    finally:
        root.handlers = handlers
        for record in hold.records:
            root.handle(record)


def run_with_dashboard(
    runtime: Runtime,
    *,
    source: str = "",
    show: Callable[[RobotDashboardApp], None] | None = None,
) -> int:
    """Run the controller under the dashboard until q, a signal's `request_stop`, or an error.

    Returns 0, or 1 when the UI failed (the controller was stopped all the same). The
    controller's own error is raised again here; `show` runs the app (tests: a pilot).
    """
    robot = RobotRun(runtime)
    app = RobotDashboardApp(robot, source=source)
    robot.start()
    try:
        with held_logs():
            (show or _run_app)(app)
    finally:
        stopped = robot.stop()
    if not stopped:
        raise BywireError(f"the controller did not stop within {STOP_TIMEOUT_S:.0f} s")
    if robot.error is not None:
        raise robot.error
    if app.return_code:
        log.error("the dashboard failed (exit %s); the controller stopped", app.return_code)
        return 1
    if robot.guard.failures:
        log.warning("%s; the controller ran on", robot.guard.failure)
    return 0


def _run_app(app: RobotDashboardApp) -> None:
    app.run()
