"""Accepting connections for bywire's servers: until asked to stop, and a bounded number at once.

Both servers (the socketcand bus and the Foxglove gate) serve each connection in threads of its
own; `Slots` bounds how many are served at once, so that connections nobody finishes (a port
scan, a web page's fetches) cannot pile up threads.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator


def accepted(listener: socket.socket, stopping: threading.Event) -> Iterator[socket.socket]:
    """Each connection `listener` accepts, until `stopping` is set (the listener's timeout is
    how often it looks) or the listener is closed."""
    while not stopping.is_set():
        try:
            sock, _ = listener.accept()
        except TimeoutError:
            continue
        except OSError:
            return
        yield sock


class Slots:
    """At most `limit` connections served at once: `take` one before, `give` it back after."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._used = 0
        self._lock = threading.Lock()

    def take(self) -> bool:
        """A slot for a new connection, or False when every one is in use."""
        with self._lock:
            if self._used >= self.limit:
                return False
            self._used += 1
            return True

    def give(self) -> None:
        with self._lock:
            self._used -= 1
