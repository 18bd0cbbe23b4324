"""The gate between the loop's writes and the watchdog's safe writes: a trip is final.

Every loop write to a port runs under that port's lock and is refused once the watchdog has
tripped, until the trip is acknowledged (`reset`). The watchdog (`trip`) sets the flag first and
then writes each port's safe level under its lock; a port whose lock is held is a loop write in
flight, perhaps stalled inside the driver. The watchdog does not wait for it before making the
other ports safe: the loop, on leaving that write, sees the trip and writes the safe level itself
before it lets the port go, and the watchdog's own thread writes it again once it gets the lock.
So after a trip no port keeps a level the loop wrote, and no loop write starts, until reset;
the loop's writes meanwhile re-assert each port's safe level (one that failed may land later).

A port's safe action may be None: the steering holds where it is (centring at speed is a swerve).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

Action = Callable[[], None]


class WriteGate:
    """Per-port locks and the trip flag, shared by the loop and the watchdog's thread."""

    def __init__(self, safe_actions: dict[str, Action | None]) -> None:
        self._safe = dict(safe_actions)
        self._locks = {port: threading.Lock() for port in safe_actions}
        self._owners: dict[str, int | None] = dict.fromkeys(safe_actions)
        self._holders = {port: _Held(self, port) for port in safe_actions}  # one each, reused
        self._tripped = False

    @property
    def tripped(self) -> bool:
        """The watchdog tripped and nobody acknowledged it yet."""
        return self._tripped

    def write(self, port: str, action: Action) -> bool:
        """The loop's write: run `action` on `port` unless tripped. True when it ran and stands.

        While tripped the port's safe level is written instead, every time: a safe write that
        failed at the trip (a DAC that NAKed) lands once the port works again."""
        with self._held(port):
            if self._tripped:
                self._write_safe(port)
                return False
            action()
            if not self._tripped:
                return True
            self._write_safe(port)  # tripped while we were inside the port
            return False

    def write_safe(self, port: str, action: Action | None = None) -> None:
        """The port's safe level (or `action`, which must write one), whatever the trip: at
        start-up and exit, and from the watchdog."""
        with self._held(port):
            if action is None:
                self._write_safe(port)
            else:
                action()

    def trip(self) -> None:
        """From the watchdog's thread: refuse the loop's writes, make every port safe."""
        self._tripped = True
        blocked = []
        for port, lock in self._locks.items():
            if lock.acquire(blocking=False):
                try:
                    self._write_safe(port)
                finally:
                    lock.release()
            else:
                blocked.append(port)
        for port in blocked:
            if self._owners[port] != threading.get_ident():  # never wait on our own thread
                self.write_safe(port)

    def reset(self) -> None:
        """The trip was acknowledged: the loop may write again."""
        self._tripped = False

    def _write_safe(self, port: str) -> None:
        action = self._safe[port]
        if action is not None:
            action()

    def _held(self, port: str) -> _Held:
        return self._holders[port]


class _Held:
    """The port's lock, with its owner recorded so the watchdog never waits on itself. It keeps
    no state of its own, so the loop and the watchdog's thread share one per port."""

    def __init__(self, gate: WriteGate, port: str) -> None:
        self._gate, self._port = gate, port

    def __enter__(self) -> None:
        self._gate._locks[self._port].acquire()
        self._gate._owners[self._port] = threading.get_ident()

    def __exit__(self, *_: object) -> None:
        self._gate._owners[self._port] = None
        self._gate._locks[self._port].release()
