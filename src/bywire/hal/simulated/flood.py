"""Other nodes' CAN traffic: 8-byte frames at low-priority ids filling a chosen share of the bus.

The benchmark's "full 500 kbit/s load" (REQUIREMENTS §8): frames are offered every
``frame_time_s / load_fraction``; a frame that finds the node's mailboxes full is dropped, so the
load never exceeds what the bus can carry and our higher-priority frames still win arbitration.
"""

from __future__ import annotations

from bywire.can_frame import MAX_STANDARD_ID, CanFrame
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.timers import PeriodicTimer, SimClock

FLOOD_ID_COUNT = 8
"""The flood cycles through this many consecutive ids, as a handful of other nodes would."""


class CanFlood:
    """Periodic 8-byte frames from one port, at ids ``first_id`` … ``first_id + 7``."""

    def __init__(self, clock: SimClock, port: SimCanPort, frame_time_s: float) -> None:
        self._clock = clock
        self._port = port
        self._frame_time_s = frame_time_s
        self._timer: PeriodicTimer | None = None
        self._first_id = 0x300
        self.frames_offered = 0

    @property
    def running(self) -> bool:
        """True while the flood is on."""
        return self._timer is not None and self._timer.running

    def start(self, load_fraction: float, first_id: int) -> None:
        """(Re)start at ``load_fraction`` (0 < load ≤ 1) of the bus."""
        if not 0.0 < load_fraction <= 1.0:
            raise ValueError(f"load_fraction must be in (0, 1], got {load_fraction}")
        if not 0 <= first_id <= MAX_STANDARD_ID - FLOOD_ID_COUNT + 1:
            raise ValueError(f"flood ids from 0x{first_id:X} do not fit in 11 bits")
        self.stop()
        self._first_id = first_id
        self._timer = PeriodicTimer(self._clock, self._frame_time_s / load_fraction, self._offer)
        self._timer.start()

    def stop(self) -> None:
        """No more frames (those already queued still go out)."""
        if self._timer is not None:
            self._timer.stop()

    def _offer(self, _tick_s: float) -> None:
        index = self.frames_offered
        self.frames_offered += 1
        frame_id = self._first_id + index % FLOOD_ID_COUNT
        payload = (index & 0xFFFF_FFFF_FFFF_FFFF).to_bytes(8, "little")
        self._port.send(CanFrame(frame_id, payload))
