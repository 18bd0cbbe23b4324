"""A simulated robot's CAN node as a python-can bus: python-can code drives a simulator in-process.

``SimPortBus(world.bus.attach("teleop"))`` is a ``can.BusABC``: ``send`` queues the frame in the
node's mailboxes (``can.CanOperationError`` when they are full, as a real driver's ENOBUFS), and
received frames are taken from the node at delivery into a thread-safe queue, so a
``can.Notifier`` thread may call ``recv`` while the simulation runs elsewhere. Message timestamps
are the simulation's time. ``send`` must run on the thread that runs the simulation's clock.
"""

from __future__ import annotations

import queue
from typing import Any

import can

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_port import SimCanPort


class SimPortBus(can.BusABC):
    """One node of a ``SimCanBus`` behind python-can's bus interface."""

    def __init__(self, port: SimCanPort, **kwargs: Any) -> None:
        super().__init__(channel=port.name, **kwargs)
        self.channel_info = f"simulated CAN node {port.name!r}"
        self._port = port
        self._received: queue.SimpleQueue[CanFrame] = queue.SimpleQueue()
        port.set_listener(self._received.put)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Queue ``msg`` on the simulated bus; CanOperationError when every mailbox is busy."""
        frame = CanFrame(msg.arbitration_id, bytes(msg.data))
        if not self._port.send(frame):
            raise can.CanOperationError(f"{self._port.name}: transmit mailboxes full")

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            if timeout is not None and timeout <= 0:
                frame = self._received.get_nowait()
            else:
                frame = self._received.get(timeout=timeout)
        except queue.Empty:
            return None, False
        message = can.Message(
            timestamp=frame.timestamp_s,
            arbitration_id=frame.arbitration_id,
            is_extended_id=False,
            data=frame.data,
            channel=self._port.name,
        )
        return message, False

    def shutdown(self) -> None:
        """Detach from the node's deliveries (frames then queue in the node again)."""
        self._port.set_listener(None)
        super().shutdown()
