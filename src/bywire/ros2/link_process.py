"""The CAN link in a process of its own, so that nothing in the ROS node can delay it.

In one process the link's thread shares the interpreter lock with rclpy's threads: on a busy
computer a thread holding the lock is preempted, and the link waits behind it however high its
own priority (a priority inversion; the ROS tier measured periods of 0.12-0.13 s, past the
robot's 100 ms CAN timeout). So the node starts the link as a child process (spawned, never
forked from a process with rclpy's threads), and talks to it over a pipe: set-points and
requests go down, a snapshot (with any service answer) comes up after every period.

`LinkProcess` offers the node the same methods as `CanLink` (`offer`, `request_enable`,
`answer`, `set_remote_stop`, `snapshot`, `now`). If the node dies, the child reads the end of
its pipe, sends one period of full brake and ends: the robot's CAN timeout does the rest.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import can

from bywire.background import OWNER
from bywire.errors import BywireError, HardwareError
from bywire.ros2.bridge import Decision
from bywire.ros2.enabling import Answer
from bywire.ros2.link import NOTHING_YET, CanLink, Snapshot
from bywire.ros2.setpoint import Refusal, Setpoint, admit
from bywire.ros2.settings import BridgeSettings, Geometry
from bywire.security.session import SecocSigner

START_TIMEOUT_S = 20.0
STOP_TIMEOUT_S = 2.0

Opener = Callable[[], tuple[can.BusABC, SecocSigner | None]]
"""Opens the bus and the signer in the child (a picklable, module-level function or partial)."""


@dataclass(frozen=True, slots=True)
class LinkOptions:
    settings: BridgeSettings
    geometry: Geometry
    fifo_priority: int | None


def _child(connection: Connection, opener: Opener, options: LinkOptions) -> None:
    """The child: open the bus, run the link, obey the pipe; report a failure in one line."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the node decides when the link stops
    try:
        bus, signer = opener()
    except BywireError as error:
        connection.send(("failure", str(error)))
        return
    link = CanLink(
        bus, options.settings, options.geometry, signer=signer, fifo_priority=options.fifo_priority
    )
    stop = threading.Event()
    lock = threading.Lock()

    def report(decision: Decision) -> None:
        with lock:
            connection.send(("state", link.snapshot(), decision.answer))

    def obey() -> None:
        try:
            while True:
                kind, *rest = connection.recv()
                if kind == "setpoint":
                    link.offer(rest[0])
                elif kind == "enable":
                    link.request_enable()
                elif kind == "remote_stop":
                    link.set_remote_stop(rest[0])
                else:
                    break
        except (EOFError, OSError):
            pass  # the node is gone
        stop.set()

    OWNER.thread(obey, name="bywire-link-pipe")  # ends with the pipe, or with this child
    connection.send(("ready",))
    try:
        link.run(stop, after_tick=report)
    except BrokenPipeError:
        pass
    finally:
        bus.shutdown()
        if signer is not None:
            signer.close()
    if link.failure is not None:
        with lock:
            connection.send(("failure", str(link.failure)))


class LinkProcess:
    """The node's handle on the link's process."""

    def __init__(self, opener: Opener, options: LinkOptions) -> None:
        self.settings = options.settings
        self.geometry = options.geometry
        self.failure: BaseException | None = None
        self._snapshot = NOTHING_YET
        self._answers: dict[int, Answer] = {}
        self._enable_calls = 0
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        context = multiprocessing.get_context("spawn")
        self._connection, child_end = context.Pipe()
        self._process = OWNER.process(
            context.Process(
                target=_child,
                args=(child_end, opener, options),
                name="bywire-can-link",
                daemon=True,
            ),
            stop=lambda: self._send("stop"),  # one period of full brake goes out
            grace_s=STOP_TIMEOUT_S,
        )
        child_end.close()
        self._await_ready()
        self._reader = OWNER.thread(self._read, name="bywire-link-reader", stop=self.close)

    def _await_ready(self) -> None:
        if not self._connection.poll(START_TIMEOUT_S):
            self.close()
            raise HardwareError("the CAN link process did not start")
        kind, *rest = self._connection.recv()
        if kind == "failure":
            self.close()
            raise HardwareError(rest[0])

    def _read(self) -> None:
        try:
            while True:
                kind, *rest = self._connection.recv()
                with self._changed:
                    if kind == "state":
                        self._snapshot = rest[0]
                        if rest[1] is not None:
                            self._answers[rest[1].request] = rest[1]
                    else:
                        self.failure = HardwareError(rest[0])
                    self._changed.notify_all()
        except (EOFError, OSError):
            with self._changed:
                self.failure = self.failure or HardwareError("the CAN link process ended")
                self._changed.notify_all()

    @property
    def alive(self) -> bool:
        return self.failure is None and self._process.is_alive()

    def now(self) -> float:
        """The clock set-points' arrival is read on: CLOCK_MONOTONIC, the same in both."""
        return time.monotonic()

    def _send(self, *message: Any) -> None:
        with contextlib.suppress(OSError):  # the reader says why the link ended
            self._connection.send(message)

    def offer(self, setpoint: Setpoint) -> Refusal | None:
        """Send a set-point down (the link judges and counts it); why it will be refused."""
        self._send("setpoint", setpoint)
        return admit(setpoint, self.settings)

    def request_enable(self) -> int:
        with self._lock:
            self._enable_calls += 1
            number = self._enable_calls
        self._send("enable")
        return number

    def answer(self, request: int, timeout_s: float) -> Answer | None:
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                done = [number for number in self._answers if number >= request]
                if done:
                    return self._answers[min(done)]
                left = deadline - time.monotonic()
                if left <= 0 or self.failure is not None or not self._changed.wait(left):
                    return None

    def set_remote_stop(self, requested: bool) -> None:
        self._send("remote_stop", requested)

    def snapshot(self) -> Snapshot:
        with self._lock:
            return self._snapshot

    def close(self) -> None:
        """Tell the link to stop (one period of full brake goes out), and wait for it."""
        self._send("stop")
        self._process.join(timeout=STOP_TIMEOUT_S)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join(timeout=STOP_TIMEOUT_S)
        self._connection.close()
