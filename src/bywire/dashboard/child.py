"""The dashboard as a child process: `bywire run --dashboard` starts it on the feed, and
`bywire dashboard` alone starts a simulated robot to attach to.

The controller and its view share nothing but a loopback socket and the terminal: the view is
`bywire dashboard --attach URL` in a process of its own, a client of the telemetry feed. A view
that is slow, frozen (SIGSTOP, a terminal that stops reading) or killed costs the controller
nothing; the server drops what the client does not take. When the view quits on `q` (exit status
0) the controller is told (`on_quit`); any other end is logged and the controller runs on.
Stopping the view never waits long: SIGTERM, a short grace, then SIGKILL (which a stopped process
also obeys), and the terminal's modes are put back as they were.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import signal
import subprocess
import sys
import termios
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from bywire.background import OWNER
from bywire.errors import BywireError
from bywire.priority import leave_realtime

STOP_GRACE_S = 0.2  # how long a view has to leave after SIGTERM before SIGKILL
TERMINAL_RESET = b"\x1b[?1049l\x1b[?25h\x1b[0m"  # leave the alternate screen, show the cursor
FEED_URL = re.compile(r"serving telemetry to Foxglove on (ws://\S+)")
START_LIMIT_S = 60.0  # a loaded machine may take long to import the simulator
log = logging.getLogger(__name__)


def bywire_command(*arguments: str) -> list[str]:
    """This interpreter running bywire with `arguments` (the installed script may be elsewhere)."""
    return [sys.executable, "-m", "bywire", *arguments]


class ViewProcess:
    """`bywire dashboard --attach URL` on this process's terminal, watched by a thread."""

    def __init__(
        self,
        url: str,
        *,
        on_quit: Callable[[], None],
        write_raw: Callable[[bytes], None] | None = None,
        terminal_fd: int = 0,
    ) -> None:
        self.url = url
        self._on_quit = on_quit
        self._write_raw = write_raw
        self._terminal_fd = terminal_fd
        self._modes: list[int | list[bytes | int]] | None = None
        self._stopping = False
        self.process: subprocess.Popen[bytes] | None = None
        self._watcher: threading.Thread | None = None

    def start(self) -> ViewProcess:
        with contextlib.suppress(termios.error, OSError):
            self._modes = termios.tcgetattr(self._terminal_fd)
        self.process = OWNER.popen(
            bywire_command("dashboard", "--attach", self.url),
            name="bywire-dashboard-view",
            stop=self.stop,
        )
        self._watcher = OWNER.thread(self._watch, name="bywire-dashboard-watch", stop=self.stop)
        return self

    @property
    def running(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def stop(self, grace_s: float = STOP_GRACE_S) -> None:
        """End the view within about `grace_s` whatever state it is in; restore the terminal."""
        self._stopping = True
        process = self.process
        if process is None:
            return
        if process.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                process.terminate()
                os.kill(process.pid, signal.SIGCONT)  # a stopped view cannot act on SIGTERM
            try:
                process.wait(grace_s)
            except subprocess.TimeoutExpired:
                process.kill()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    process.wait(grace_s)
        self._restore_terminal()

    def _restore_terminal(self) -> None:
        if self._modes is not None:
            with contextlib.suppress(termios.error, OSError):
                termios.tcsetattr(self._terminal_fd, termios.TCSANOW, self._modes)
        if self._write_raw is not None:
            self._write_raw(TERMINAL_RESET)

    def _watch(self) -> None:
        leave_realtime()
        assert self.process is not None
        status = self.process.wait()
        if self._stopping:
            return
        if status == 0:
            log.info("the dashboard quit: stopping the controller")
            self._on_quit()
        else:
            log.warning("the dashboard ended (exit status %s); the controller runs on", status)


ROBOT_STOP_S = 5.0  # how long the simulated robot has to stop safe and summarise on Ctrl-C
SUMMARY_WAIT_S = 2.0  # how long the verdict waits for the ended run's summary to be read


def scenario_verdict(summary: dict[str, Any]) -> str:
    """One line from `bywire sim --json`'s summary: PASSED or FAILED with the count, the
    expectations a run stopped early never reached, or why the verdict does not apply."""
    statuses = [expectation["status"] for expectation in summary["expectations"]]
    passed, unreached = statuses.count("pass"), statuses.count("not reached")
    counted = f"{passed} of {len(statuses)} passed"
    if unreached:
        counted += f", {unreached} not reached"
    if summary.get("not_applicable"):
        return f"not applicable to this robot ({counted})"
    if not summary["passed"]:
        return f"FAILED ({counted})"
    return f"not decided ({counted}: the run ended first)" if unreached else f"PASSED ({counted})"


class SimFeed:
    """`bywire sim --realtime --foxglove 127.0.0.1:0 …` as a child: a robot for the view."""

    def __init__(
        self,
        arguments: Sequence[str],
        *,
        on_started: Callable[[subprocess.Popen[str]], None] | None = None,
    ) -> None:
        """Start the robot and wait for its feed's address; `on_started` gets its process at
        once (for whoever must stop it should this process be ended meanwhile)."""
        command = bywire_command(
            "sim", "--realtime", "--json", "--foxglove", "127.0.0.1:0", *arguments
        )
        self.process: subprocess.Popen[str] = OWNER.popen(
            command,
            name="bywire-dashboard-robot",
            stop=self._interrupt,
            grace_s=ROBOT_STOP_S,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        if on_started is not None:
            on_started(self.process)
        self.lines: list[str] = []
        self._summary: list[str] = []  # the run's summary, as JSON, once it has ended
        # Both readers end when the robot does: asked to end, they stop it (Ctrl-C) and wait.
        self._summary_read = OWNER.thread(
            self._read_summary,
            name="bywire-dashboard-robot-summary",
            stop=self._interrupt,
            join_s=ROBOT_STOP_S,
        )
        self.url = self._wait_for_url()
        self._drain = OWNER.thread(
            self._keep_reading,
            name="bywire-dashboard-robot-log",
            stop=self._interrupt,
            join_s=ROBOT_STOP_S,
        )

    def _read_summary(self) -> None:
        leave_realtime()
        assert self.process.stdout is not None
        self._summary.append(self.process.stdout.read())

    def verdict(self) -> str | None:
        """The scenario's verdict once the run has ended ("PASSED (7 of 7 passed)"); None
        while it runs."""
        if self.process.poll() is None:
            return None
        self._summary_read.join(SUMMARY_WAIT_S)
        try:
            summary = json.loads("".join(self._summary))
        except json.JSONDecodeError:
            return f"the run ended without a summary (exit status {self.process.returncode})"
        return scenario_verdict(summary)

    def _wait_for_url(self) -> str:
        assert self.process.stderr is not None
        deadline_s = time.monotonic() + START_LIMIT_S
        for line in self.process.stderr:
            self.lines.append(line.rstrip("\n"))
            found = FEED_URL.search(line)
            if found:
                return found.group(1)
            if time.monotonic() > deadline_s:
                break
        self.stop()
        last = self.lines[-1] if self.lines else "no output"
        raise BywireError(f"the simulated robot did not start: {last.removeprefix('bywire ')}")

    def _keep_reading(self) -> None:
        leave_realtime()
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.lines.append(line.rstrip("\n"))

    def _interrupt(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)

    def stop(self, timeout_s: float = ROBOT_STOP_S) -> int:
        """Ctrl-C for the simulated robot (it stops safe and summarises); its exit status."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                return self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.process.kill()
        return self.process.wait()
