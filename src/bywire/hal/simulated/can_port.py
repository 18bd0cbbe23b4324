"""One node's CAN controller on the simulated bus: three transmit mailboxes, a filter, an rx queue.

A ``CanPort``. ``send`` refuses a frame (returns False) when all mailboxes hold frames that have
not yet gone out, or while the node is bus-off, as bxCAN does; the controller's reporting task
must cope with that (R-CANTX). Received frames wait in a bounded queue, like a socket buffer; a
frame that finds it full is dropped. ``link`` says both: bus-off, and the frames dropped.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
from typing import Protocol

from bywire.can_frame import CanFrame, check_can_frame
from bywire.hal.ports import LINK_UP, LinkState
from bywire.hal.simulated.timers import SimClock

DEFAULT_RX_CAPACITY = 1024


class Wire(Protocol):
    """What a port needs of the bus it is attached to (``SimCanBus`` is one): the port sits
    below the bus, so the bus imports the port and never the other way."""

    @property
    def clock(self) -> SimClock: ...
    def queue_order(self) -> int: ...
    def request_arbitration(self) -> None: ...


class SimCanPort:
    """A node on a ``SimCanBus``; create it with ``bus.attach(...)``."""

    def __init__(
        self,
        bus: Wire,
        name: str,
        wake_on_receive: bool,
        accept_ids: Iterable[int] | None,
        *,
        tx_mailboxes: int = 3,
        rx_capacity: int = DEFAULT_RX_CAPACITY,
    ) -> None:
        self.name = name
        self.wake_on_receive = wake_on_receive
        self.accept_ids: frozenset[int] | None = None
        self.set_filter(accept_ids)
        self.bus_off = False
        self.frames_sent = 0
        self.frames_received = 0
        self.send_refused = 0
        self.rx_overflows = 0
        self._bus = bus
        self._tx_mailboxes = tx_mailboxes
        self.mailboxes: list[tuple[int, int, CanFrame]] = []
        """The frames waiting to go out, as (id, queue order, frame): read by the bus, which
        asks only a node that holds one for its offer (`next_pending`)."""
        self._rx: deque[CanFrame] = deque()
        self._rx_capacity = rx_capacity
        self._listener: Callable[[CanFrame], None] | None = None

    def send(self, frame: CanFrame) -> bool:
        """Queue a frame for the bus; False when every mailbox is busy or the node is bus-off."""
        check_can_frame(frame)
        if self.bus_off or len(self.mailboxes) >= self._tx_mailboxes:
            self.send_refused += 1
            return False
        self.mailboxes.append((frame.arbitration_id, self._bus.queue_order(), frame))
        self._bus.request_arbitration()
        return True

    def receive(self) -> list[CanFrame]:
        """Every frame received since the last call, oldest first."""
        frames = list(self._rx)
        self._rx.clear()
        return frames

    @property
    def link(self) -> LinkState:
        """Down while bus-off; every frame dropped from the full receive queue a failed receive."""
        if not self.bus_off and not self.rx_overflows:
            return LINK_UP
        return LinkState(down=self.bus_off, receive_failures=self.rx_overflows)

    @property
    def pending(self) -> int:
        """Frames waiting in the mailboxes."""
        return len(self.mailboxes)

    def set_filter(self, accept_ids: Iterable[int] | None) -> None:
        """Accept only these ids (None: every id), like a hardware acceptance filter."""
        self.accept_ids = None if accept_ids is None else frozenset(accept_ids)

    def set_tx_mailboxes(self, count: int) -> None:
        """Resize the transmit queue (a SecOC sender queues two frames per command)."""
        self._tx_mailboxes = count

    def set_listener(self, listener: Callable[[CanFrame], None] | None) -> None:
        """Hand each accepted frame to ``listener`` at delivery instead of queueing it."""
        self._listener = listener

    def enter_bus_off(self) -> None:
        """Fault injection: the node goes bus-off; its pending frames are lost."""
        self.bus_off = True
        self.mailboxes.clear()

    def recover_bus_off(self) -> None:
        """Leave bus-off (after the 128 x 11 recessive bits a real controller waits for)."""
        self.bus_off = False

    # --- called by the bus --------------------------------------------------------------------

    def next_pending(self) -> tuple[int, int, CanFrame] | None:
        """The mailbox the controller offers for arbitration: lowest id, then oldest."""
        if self.bus_off or not self.mailboxes:
            return None
        return min(self.mailboxes)  # (id, queue order, frame): the order is unique

    def transmitted(self, frame: CanFrame) -> None:
        """The bus acknowledged ``frame``: free its mailbox."""
        for index, (_, _, pending) in enumerate(self.mailboxes):
            if pending is frame:
                del self.mailboxes[index]
                self.frames_sent += 1
                return

    def deliver(self, frame: CanFrame) -> None:
        """A frame reached this node: filter, queue or hand over, and wake the clock if asked."""
        if self.accept_ids is not None and frame.arbitration_id not in self.accept_ids:
            return
        self.frames_received += 1
        if self._listener is not None:
            self._listener(frame)
        elif len(self._rx) >= self._rx_capacity:
            self.rx_overflows += 1
        else:
            self._rx.append(frame)
        if self.wake_on_receive:
            self._bus.clock.notify_input()
