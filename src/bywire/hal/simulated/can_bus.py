"""Simulated CAN bus: frames take their real time on the wire, lower ids win, faults on demand.

Each attached ``SimCanPort`` is one node's controller with bxCAN's three transmit mailboxes. The
bus sends one frame at a time: when it falls idle, every node offers its lowest-id pending frame
and the lowest id wins arbitration (equal ids: the one queued first). A frame occupies the bus
for ``frame_bits(dlc) / bitrate_bps`` and is delivered to every other node, stamped with the time
its last bit left the wire. Faults: ``unplug()`` (nothing is delivered, frames wait in the
mailboxes), a port's ``enter_bus_off()``, and ``flood()`` (other nodes' low-priority traffic).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import partial

from bywire.can_frame import CanFrame
from bywire.control.values import slot_init
from bywire.hal.simulated.can_port import DEFAULT_RX_CAPACITY, SimCanPort
from bywire.hal.simulated.flood import CanFlood
from bywire.hal.simulated.timers import SimClock
from bywire.protocol.bittiming import frame_bits, frame_time_s

DEFAULT_BITRATE_BPS = 500_000
DEFAULT_LOG_LIMIT = 20_000
FLOOD_PORT_NAME = "flood"


@dataclass(frozen=True, slots=True)
class LoggedFrame:
    """One frame as it crossed the bus: end-of-frame time, id, payload and sending node."""

    time_s: float
    arbitration_id: int
    data: bytes
    sender: str

    def __init__(self, time_s: float, arbitration_id: int, data: bytes, sender: str) -> None:
        object.__setattr__(self, "time_s", time_s)
        object.__setattr__(self, "arbitration_id", arbitration_id)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "sender", sender)


slot_init(LoggedFrame)


class SimCanBus:
    """An in-memory CAN bus at ``bitrate_bps`` on the simulation clock.

    ``log`` keeps the latest ``log_limit`` delivered frames (None: all, 0: none); monitors added
    with ``add_monitor`` see every frame, for tools that stream a long run to a file.
    """

    def __init__(
        self,
        clock: SimClock,
        bitrate_bps: int = DEFAULT_BITRATE_BPS,
        log_limit: int | None = DEFAULT_LOG_LIMIT,
    ) -> None:
        if bitrate_bps <= 0:
            raise ValueError(f"bitrate_bps must be > 0, got {bitrate_bps}")
        self.clock = clock
        self.bitrate_bps = bitrate_bps
        self.log: deque[LoggedFrame] = deque(maxlen=log_limit)
        self.bits_by_sender: dict[str, int] = {}
        self.plugged = True
        self._ports: list[SimCanPort] = []
        self._monitors: list[Callable[[LoggedFrame], None]] = []
        self._busy = False  # arbitrating or transmitting: a new frame waits its turn
        self._free_at_s = clock.now()
        self._flood: CanFlood | None = None
        self._queue_order = itertools.count()

    def attach(
        self,
        name: str,
        wake_on_receive: bool = False,
        accept_ids: Iterable[int] | None = None,
        tx_mailboxes: int = 3,
        rx_capacity: int = DEFAULT_RX_CAPACITY,
    ) -> SimCanPort:
        """A new node on the bus; ``accept_ids`` is its hardware filter (None: every id)."""
        if any(port.name == name for port in self._ports):
            raise ValueError(f"a node named {name!r} is already on the bus")
        port = SimCanPort(
            self,
            name,
            wake_on_receive,
            accept_ids,
            tx_mailboxes=tx_mailboxes,
            rx_capacity=rx_capacity,
        )
        self._ports.append(port)
        return port

    def frame_time_s(self, dlc: int) -> float:
        """Seconds a frame with ``dlc`` data bytes holds the bus."""
        return frame_time_s(dlc, self.bitrate_bps)

    def bits_sent(self, sender: str | None = None) -> int:
        """Bits put on the wire so far by one node, or by all."""
        if sender is None:
            return sum(self.bits_by_sender.values())
        return self.bits_by_sender.get(sender, 0)

    def add_monitor(self, monitor: Callable[[LoggedFrame], None]) -> None:
        """Call ``monitor`` with every frame the bus delivers."""
        self._monitors.append(monitor)

    def unplug(self) -> None:
        """Cut the bus: nothing is delivered; frames wait in their mailboxes until ``plug()``."""
        self.plugged = False

    def plug(self) -> None:
        """Reconnect: pending frames go out again, in priority order."""
        self.plugged = True
        self.request_arbitration()

    def flood(self, load_fraction: float, first_id: int = 0x300) -> None:
        """Other nodes' 8-byte frames (ids from ``first_id``) filling this share of the bus."""
        if self._flood is None:
            port = self.attach(FLOOD_PORT_NAME, accept_ids=())
            self._flood = CanFlood(self.clock, port, self.frame_time_s(8))
        self._flood.start(load_fraction, first_id)

    def stop_flood(self) -> None:
        """End the other nodes' traffic."""
        if self._flood is not None:
            self._flood.stop()

    def queue_order(self) -> int:
        """A bus-wide sequence number: equal ids go out in the order they were queued."""
        return next(self._queue_order)

    def request_arbitration(self) -> None:
        """Called by a port with a new frame: start arbitrating once the bus is free."""
        if self._busy or not self.plugged:
            return
        self._busy = True
        start_s = max(self.clock.now(), self._free_at_s)
        # Scheduled, not run now: nodes queuing at the same instant all take part.
        self.clock.call_at(start_s, partial(self._arbitrate, start_s))

    def _arbitrate(self, start_s: float) -> None:
        best: tuple[int, int, CanFrame] | None = None
        sender: SimCanPort | None = None
        if self.plugged:
            for port in self._ports:
                if not port.mailboxes:  # most nodes have nothing to send: not asked
                    continue
                offer = port.next_pending()
                # (id, queue order) decides; the order is unique, so frames are never compared
                if offer is not None and (best is None or offer < best):
                    best, sender = offer, port
        if best is None or sender is None:
            self._busy = False
            return
        frame = best[2]
        bits = frame_bits(len(frame.data))
        end_s = start_s + bits / self.bitrate_bps
        self._busy = True
        self.clock.call_at(end_s, partial(self._complete, sender, frame, bits, end_s))

    def _complete(self, sender: SimCanPort, frame: CanFrame, bits: int, end_s: float) -> None:
        self._free_at_s = end_s
        if not self.plugged:
            # No acknowledge: the frame stays in its mailbox and is sent again after plug().
            self._busy = False
            return
        sender.transmitted(frame)
        self.bits_by_sender[sender.name] = self.bits_by_sender.get(sender.name, 0) + bits
        frame_id = frame.arbitration_id
        delivered = CanFrame(frame_id, frame.data, end_s)
        for port in self._ports:
            accept_ids = port.accept_ids  # its filter, looked at here: most frames pass most by
            if port is not sender and (accept_ids is None or frame_id in accept_ids):
                port.deliver(delivered)
        if self.log.maxlen != 0 or self._monitors:
            entry = LoggedFrame(end_s, frame.arbitration_id, frame.data, sender.name)
            self.log.append(entry)
            for monitor in self._monitors:
                monitor(entry)
        # The next frame starts right after this one's intermission (already in frame_bits).
        self._arbitrate(end_s)
