"""The raw CAN frames of `bywire run` on the feed: the CAN port, wrapped where it is built.

`TappedCanPort` stands between the runtime and the real port: every frame the controller sends
(that the controller took) and every frame it receives is queued into the feed's outbox as a
`CanCapture`, stamped with the clock time the frame carries. One append per frame, no I/O, no
lock held beyond the outbox's; the runtime never knows.
"""

from __future__ import annotations

from bywire.can_frame import CanFrame
from bywire.hal.ports import CanPort, LinkState
from bywire.telemetry.capture import CanCapture, Capture
from bywire.telemetry.outbox import Outbox

SENT_BY = "bywire"  # the sender of the frames the controller sends; received ones carry ""


class TappedCanPort:
    """A `CanPort` that queues a copy of each frame crossing it into `outbox`."""

    def __init__(self, port: CanPort, outbox: Outbox[Capture]) -> None:
        self.port = port
        self._put = outbox.put

    def send(self, frame: CanFrame) -> bool:
        sent = self.port.send(frame)
        if sent:
            self._put(CanCapture(frame.timestamp_s, frame.arbitration_id, frame.data, SENT_BY))
        return sent

    def receive(self) -> list[CanFrame]:
        frames = self.port.receive()
        for frame in frames:
            self._put(CanCapture(frame.timestamp_s, frame.arbitration_id, frame.data, ""))
        return frames

    @property
    def link(self) -> LinkState:
        return self.port.link
