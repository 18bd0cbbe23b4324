"""The cost of looking, as benchmark phases: the telemetry feed on with a Foxglove client
attached ("feed"), and the dashboard as a child process on it ("dashboard").

The feed's server starts before the controller runs, as in `bywire run`; at a looking phase's
start the tap is attached to the loop (and to the bus, for the CAN channel) and the onlooker's
process is started from a helper thread, so that the phase measures the controller while it is
watched, the attaching moment included; at its end the process is stopped and the tap detached.
The onlookers are separate processes, as Foxglove and `bywire run --dashboard`'s view are.
"""

from __future__ import annotations

import contextlib
import os
import pty
import subprocess
import sys
import threading

from bywire.background import OWNER
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.simulated.world import SimWorld
from bywire.loopback import Endpoint
from bywire.priority import leave_realtime
from bywire.runtime.loop import Runtime
from bywire.telemetry.feed import FeedOptions, new_outbox, open_sinks

LOOKING_PHASES = ("feed", "dashboard")
STOP_GRACE_S = 2.0


class Onlookers:
    """The feed of `runtime` on a free loopback port, and whoever looks at it in a phase."""

    def __init__(self, runtime: Runtime, world: SimWorld) -> None:
        options = FeedOptions(foxglove=Endpoint("127.0.0.1", 0))
        self._stack = contextlib.ExitStack()
        outbox = new_outbox(options, virtual_time=False)
        sinks = self._stack.enter_context(
            open_sinks(options, runtime.clock, virtual_time=False, outbox=outbox)
        )
        self.url = f"ws://127.0.0.1:{sinks.port}"
        self.tap = sinks.tap(runtime)
        self._active = False
        world.bus.add_monitor(self._frame)
        self._process: subprocess.Popen[str] | None = None
        self._terminal: int | None = None
        self.received: dict[str, int] = {}
        self._helper: threading.Thread | None = None

    def start(self, phase: str) -> None:
        """From the loop (a clock callback): attach the tap, start the onlooker elsewhere."""
        self.tap.attach()
        self._active = True
        self._helper = OWNER.thread(self._spawn, phase, name=f"bywire-bench-onlooker-start {phase}")

    def stop(self, phase: str) -> None:
        """From the loop: detach the tap; the onlooker is stopped by a helper thread."""
        self._active = False
        self.tap.detach()
        helper = self._helper
        OWNER.thread(self._end, phase, helper, name=f"bywire-bench-onlooker-end {phase}")

    def close(self) -> None:
        """After the run: the last onlooker gone, the server stopped."""
        self._end("", self._helper)
        self._stack.close()

    def _frame(self, frame: LoggedFrame) -> None:
        if self._active:
            self.tap.can_frame(frame.time_s, frame.arbitration_id, frame.data, frame.sender)

    def _spawn(self, phase: str) -> None:
        leave_realtime()  # the harness's helpers run as `bywire run --dashboard`'s do
        if phase == "feed":
            command = [sys.executable, "-m", "bywire.bench.onlooker", self.url]
            self._process = OWNER.popen(
                command, name="bywire-bench-onlooker", stdout=subprocess.PIPE, text=True
            )
            return
        master, slave = pty.openpty()
        self._process = OWNER.popen(
            [sys.executable, "-m", "bywire", "dashboard", "--attach", self.url],
            name="bywire-bench-dashboard",
            stdin=slave,
            stdout=slave,
            stderr=slave,
            env={**os.environ, "TERM": "xterm-256color"},
            start_new_session=True,
            text=True,
        )
        os.close(slave)
        self._terminal = master
        OWNER.thread(_discard, master, name="bywire-bench-terminal")  # ends when the pty closes

    def _end(self, phase: str, helper: threading.Thread | None) -> None:
        leave_realtime()
        if helper is not None:
            helper.join()
        process = self._process
        if process is None:
            return
        self._process = None
        process.terminate()
        try:
            out, _ = process.communicate(timeout=STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            process.kill()
            out, _ = process.communicate()
        if phase == "feed" and out and out.strip().isdigit():
            self.received[phase] = int(out.strip())
        if self._terminal is not None:
            with contextlib.suppress(OSError):
                os.close(self._terminal)
            self._terminal = None


def _discard(master: int) -> None:
    """Read the view's terminal, as a terminal emulator would, and drop it."""
    with contextlib.suppress(OSError):
        while os.read(master, 65536):
            pass
