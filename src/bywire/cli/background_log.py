"""Log lines written to the terminal by a thread of their own, so that no caller ever waits on it.

A terminal can stop reading (XOFF, a frozen SSH session, a stopped view sharing it): a write to
it then blocks, and a controller that logs from its main thread would block with it, signals
unanswered and hardware never closed. `BackgroundLog` is a logging handler whose `emit` only
appends to a bounded queue; a daemon thread writes the lines with `os.write` (no Python file
object, so no lock that the interpreter's exit could wait on). While a view owns the terminal,
`hold()` keeps the lines back and `resume()` lets them out.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import os
import threading
import time

from bywire.background import OWNER
from bywire.priority import leave_realtime

HELD_LINES = 1000  # the newest ones are kept when more come while the terminal is held


class BackgroundLog(logging.Handler):
    """Formats in the caller's thread, writes to `fd` in its own; never blocks the caller."""

    def __init__(self, fd: int = 2, capacity: int = HELD_LINES) -> None:
        super().__init__()
        self._fd = fd
        self._pending: collections.deque[bytes] = collections.deque(maxlen=capacity)
        self._ready = threading.Condition(threading.Lock())
        self._held = False
        self._writing = False
        self._closing = False
        self._thread = OWNER.thread(self._write, name="bywire-log", stop=self.close)

    def emit(self, record: logging.LogRecord) -> None:
        try:
            line = (self.format(record) + "\n").encode(errors="replace")
        except Exception:  # logging's own rule: a bad record never raises into the caller
            self.handleError(record)
            return
        self.write_raw(line)

    def write_raw(self, data: bytes) -> None:
        """Queue bytes as they are (a terminal's reset sequence, say)."""
        with self._ready:
            self._pending.append(data)
            self._ready.notify()

    def hold(self) -> None:
        """Keep every line back (a view owns the terminal)."""
        with self._ready:
            self._held = True

    def resume(self) -> None:
        """Write the lines held back, and every later one (not `release`: that is
        `logging.Handler`'s lock)."""
        with self._ready:
            self._held = False
            self._ready.notify()

    def drain(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for every queued line to be written; False if the terminal
        did not take them (the process may end anyway: the writer is a daemon thread)."""
        deadline_s = time.monotonic() + timeout_s
        with self._ready:
            while self._pending or self._writing:
                left_s = deadline_s - time.monotonic()
                if left_s <= 0:
                    return False
                self._ready.wait(min(left_s, 0.01))
        return True

    def close(self) -> None:
        """The writer thread writes what is queued (unless held) and ends; later lines are
        dropped (logging's own shutdown calls this too)."""
        with self._ready:
            self._closing = True
            self._ready.notify_all()
        super().close()

    def _write(self) -> None:
        leave_realtime()  # a log line never competes with the loop at its priority
        while True:
            with self._ready:
                while (self._held or not self._pending) and not self._closing:
                    self._ready.wait()
                if self._closing and (self._held or not self._pending):
                    return
                chunk = b"".join(self._pending)
                self._pending.clear()
                self._writing = True
            with contextlib.suppress(OSError):  # the terminal has gone: nothing to tell it
                view = memoryview(chunk)
                while view:
                    view = view[os.write(self._fd, view) :]
            with self._ready:
                self._writing = False
                self._ready.notify_all()


def install(log_format: str, level: int, fd: int = 2) -> BackgroundLog:
    """Make a `BackgroundLog` on `fd` the root logger's only handler; returns it."""
    handler = BackgroundLog(fd)
    handler.setFormatter(logging.Formatter(log_format))
    root = logging.getLogger()
    for old in root.handlers[:]:
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(level)
    return handler
