"""The gate between the loop's writes and the watchdog's safe writes: a trip is final.

Every loop write to a port runs under that port's lock and is refused once the watchdog has
tripped, until the trip is acknowledged (`reset`). The watchdog (`trip`) sets the flag first and
then writes each port's safe level under its lock; a port whose lock is held is a loop write in
flight, perhaps stalled inside the driver. The watchdog does not wait for it before making the
other ports safe: the loop, on leaving that write, sees the trip and writes the safe level itself
before it lets the port go, and the watchdog's own thread writes it again once it gets the lock.
So after a trip no port keeps a level the loop wrote, and no loop write starts, until reset;
the loop's writes meanwhile re-assert each port's safe level (one that failed may land later).

The ports are listed in order of importance (motors' enable line, e-brake, hydraulic brake,
DAC, ...): the watchdog makes them safe in that order, and a port whose safe write fails (a dead
line, a driver that raises) is reported in `failures` and passed over, never the end of it.

Every loop write is timed on the hardware clock against the write budget
(`bywire.runtime.timing`), except the ports the actuators time themselves (the DAC, per
transfer): a write that hangs in its driver is a fault, not just a slow pass.

A port's safe action may be None: the steering holds where it is (centring at speed is a swerve).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Collection

from bywire.runtime.timing import Overruns

Action = Callable[[], None]


class WriteGate:
    """Per-port locks and the trip flag, shared by the loop and the watchdog's thread."""

    def __init__(
        self,
        safe_actions: dict[str, Action | None],
        *,
        now: Callable[[], float] | None = None,
        overruns: Overruns | None = None,
        untimed: Collection[str] = (),
    ) -> None:
        """`safe_actions` in order of importance; `now` and `overruns` time the loop's writes
        (ports in `untimed` excepted) against `overruns.budgets.write_budget_s`."""
        self._safe = dict(safe_actions)
        self._now = now
        self._overruns = overruns
        self._budget_s = math.inf if overruns is None else overruns.budgets.write_budget_s
        self._timed = frozenset(safe_actions) - frozenset(untimed)
        self.failures: list[tuple[str, str]] = []
        """(port, what went wrong) for every safe write that failed at a trip, oldest first."""
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
            now = self._now
            if now is None or port not in self._timed:
                action()
            else:
                started_s = now()
                action()
                ended_s = now()
                self._timed_out(port, ended_s - started_s, ended_s)
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
        """From the watchdog's thread: refuse the loop's writes, make every port safe, in order
        of importance, going on past any that fails (each is kept in `failures`)."""
        self._tripped = True
        blocked = []
        for port, lock in self._locks.items():
            if lock.acquire(blocking=False):
                try:
                    self._try_safe(port)
                finally:
                    lock.release()
            else:
                blocked.append(port)
        for port in blocked:
            if self._owners[port] != threading.get_ident():  # never wait on our own thread
                with self._held(port):
                    self._try_safe(port)

    def _try_safe(self, port: str) -> None:
        try:
            self._write_safe(port)
        except Exception as error:
            self.failures.append((port, str(error) or type(error).__name__))

    def _timed_out(self, port: str, spent_s: float, ended_s: float) -> None:
        if self._overruns is not None:
            self._overruns.check(f"{port} write", spent_s, self._budget_s, ended_s)

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
