"""The simulated bus on a real CAN interface: every frame out to a python-can bus, its frames in.

`bywire sim -i socketcan -c vcan0` (or a USB adapter's interface) puts the simulated robot's CAN
side on that bus: candump, cansend, SavvyCAN or a ROS SocketCAN driver see the controller's
reports (and the simulated computer's commands) and drive it; everything else stays simulated.
As with the socketcand bridge (`bridge.py`), frames cross between the simulator's thread and the
interface only through a thread-safe queue: the bus monitor (simulator thread) sends each frame
delivered on the simulated bus out, a thread receives the interface's frames into a queue, and a
timer on the simulation clock (every 2 ms) queues each on a node of its own, `outside`, so the
bus arbitrates them like any other node's. The outside node's own frames are not sent back out.
Real time only: virtual time outruns any real bus.
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections.abc import Iterator

import can

from bywire.background import OWNER
from bywire.can_frame import CanFrame
from bywire.errors import FrameError
from bywire.hal.simulated.can_bus import LoggedFrame, SimCanBus
from bywire.hal.simulated.timers import PeriodicTimer

POLL_PERIOD_S = 0.002
NODE = "outside"
NODE_TX_QUEUE = 10  # a SocketCAN interface's default txqueuelen
RECEIVE_TIMEOUT_S = 0.1


class SimBusOnInterface:
    """Connects `bus` to `outside`; counts what crossed and what was refused."""

    def __init__(self, bus: SimCanBus, outside: can.BusABC) -> None:
        self._bus, self._outside = bus, outside
        self._port = bus.attach(NODE, accept_ids=(), tx_mailboxes=NODE_TX_QUEUE)
        self._inbox: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None
        self._poll = PeriodicTimer(bus.clock, POLL_PERIOD_S, self._take)
        self.sent = self.send_refused = self.received = self.receive_refused = 0
        bus.add_monitor(self._forward)

    def start(self) -> None:
        self._thread = OWNER.thread(
            self._receive, name="bywire-netbus-interface", stop=self._closing.set
        )
        self._poll.start()

    def stop(self) -> None:
        """Stop taking the interface's frames (the bus's frames go out until it shuts down)."""
        self._poll.stop()
        self._closing.set()
        if self._thread is not None:
            self._thread.join(timeout=RECEIVE_TIMEOUT_S * 20)

    def _forward(self, frame: LoggedFrame) -> None:
        if frame.sender == NODE:
            return
        message = can.Message(
            arbitration_id=frame.arbitration_id, data=frame.data, is_extended_id=False
        )
        try:
            self._outside.send(message, timeout=0.0)
        except (can.CanError, OSError):  # a full queue or a bus that is down: counted
            self.send_refused += 1
            return
        self.sent += 1

    def _receive(self) -> None:
        while not self._closing.is_set():
            try:
                message = self._outside.recv(RECEIVE_TIMEOUT_S)
            except (can.CanError, OSError):
                self._closing.wait(RECEIVE_TIMEOUT_S)  # the interface is down for now
                continue
            if message is not None and not message.is_error_frame:
                self._inbox.put(message)

    def _take(self, _tick_s: float) -> None:
        while True:
            try:
                message = self._inbox.get_nowait()
            except queue.Empty:
                return
            frame = CanFrame(message.arbitration_id, bytes(message.data), self._bus.clock.now())
            try:
                taken = not (message.is_extended_id or message.is_remote_frame) and (
                    self._port.send(frame)
                )
            except FrameError:
                taken = False
            self.received += taken
            self.receive_refused += not taken


@contextlib.contextmanager
def on_interface(bus: SimCanBus, outside: can.BusABC) -> Iterator[SimBusOnInterface]:
    """`bus` on `outside` while the block runs; `outside` is shut down at the end."""
    bridge = SimBusOnInterface(bus, outside)
    bridge.start()
    try:
        yield bridge
    finally:
        bridge.stop()
        outside.shutdown()
