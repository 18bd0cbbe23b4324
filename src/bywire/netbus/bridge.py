"""The simulated bus on the network: every frame out to socketcand clients, theirs onto the bus.

The simulator is single-threaded on its clock, the server has threads of its own. Frames cross
between them through thread-safe queues only: the bus monitor (simulator thread) enqueues each
delivered frame for the clients; a timer on the simulation clock (simulator thread, every 2 ms)
takes the clients' frames from the server's inbox and queues each on its client's own node, so
the bus arbitrates them like any other node's. Each client is one node (``remote1``, …), and a
client never gets its own frames back, as on SocketCAN.

On a RealtimeClock the 2 ms poll bounds a client frame's extra latency. On a VirtualClock the
poll still runs, but virtual time outruns any client: ``bywire sim --serve`` needs ``--realtime``.
"""

from __future__ import annotations

import contextlib
import queue
import time
from collections.abc import Iterator

from bywire.can_frame import CanFrame
from bywire.errors import FrameError
from bywire.hal.simulated.can_bus import LoggedFrame, SimCanBus
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.loopback import Endpoint
from bywire.netbus.server import SocketcandServer

POLL_PERIOD_S = 0.002
NODE_PREFIX = "remote"
NODE_TX_QUEUE = 10  # a client is a Linux SocketCAN socket: txqueuelen 10


class SimBusBridge:
    """Connects ``bus`` and ``server``; timestamps sent to clients are ``time_s + wall_offset_s``.

    ``refused`` counts client frames the bus could not take (extended id, queue full).
    """

    def __init__(self, bus: SimCanBus, server: SocketcandServer, wall_offset_s: float) -> None:
        self.server = server
        self.refused = 0
        self._bus = bus
        self._wall_offset_s = wall_offset_s
        self._ports: dict[int, SimCanPort] = {}
        self._client_by_node: dict[str, int] = {}
        self._poll = PeriodicTimer(bus.clock, POLL_PERIOD_S, self._take_client_frames)
        bus.add_monitor(self._forward)

    def start(self) -> None:
        """Begin taking the clients' frames onto the bus."""
        self._poll.start()

    def stop(self) -> None:
        """Stop taking the clients' frames; the bus's frames go out until the server closes."""
        self._poll.stop()

    def _forward(self, frame: LoggedFrame) -> None:
        origin = self._client_by_node.get(frame.sender, 0)
        timestamp_s = frame.time_s + self._wall_offset_s
        self.server.publish(frame.arbitration_id, timestamp_s, frame.data, origin)

    def _take_client_frames(self, tick_s: float) -> None:
        while True:
            try:
                number, request = self.server.inbox.get_nowait()
            except queue.Empty:
                return
            frame = CanFrame(request.arbitration_id, request.data, self._bus.clock.now())
            try:
                taken = not request.is_extended_id and self._port(number).send(frame)
            except FrameError:
                taken = False
            self.refused += not taken

    def _port(self, number: int) -> SimCanPort:
        port = self._ports.get(number)
        if port is None:
            name = f"{NODE_PREFIX}{number}"
            port = self._bus.attach(name, accept_ids=(), tx_mailboxes=NODE_TX_QUEUE)
            self._ports[number], self._client_by_node[name] = port, number
        return port


@contextlib.contextmanager
def serve_bus(bus: SimCanBus, endpoint: Endpoint, start_s: float) -> Iterator[SimBusBridge]:
    """Serve ``bus`` on ``endpoint`` while the block runs (``bridge.server.address``: where).

    ``start_s`` is the simulation time taken as the wall clock's now, as the CAN log does.
    """
    with SocketcandServer(endpoint) as server:
        bridge = SimBusBridge(bus, server, time.time() - start_s)
        bridge.start()
        try:
            yield bridge
        finally:
            bridge.stop()
