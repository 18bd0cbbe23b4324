"""Simulated UART receiver: bytes arrive one by one at the line's baud rate, with an idle interrupt.

A ``ByteStream``. Every byte carries the time its stop bit ends; ``read_available`` returns only
the bytes that have arrived, so a read in the middle of an IBUS frame gets part of it, as on the
robot. The line sends one byte at a time: a burst written while the line is busy queues behind
the bytes already on it. At the end of each burst the clock is woken, as the UART's idle-line
interrupt wakes the controller. ``fail()`` takes the receiving device away (a USB adapter
pulled): the bytes on the line are lost and ``link`` says the port is down until ``restore()``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from bywire.hal.ports import LINK_UP, LinkState
from bywire.hal.simulated.timers import SimClock
from bywire.protocol import ibus

BITS_PER_BYTE_8N1 = 10
# Floating-point slack, in byte times, when comparing an arrival time with now: a byte due at
# exactly now has arrived even if the sum that computed its time rounded up.
_BYTE_SLACK = 1e-9
_GONE = LinkState(down=True)


@dataclass(slots=True)
class _Burst:
    """Bytes sent back to back: byte i's stop bit ends at first_arrival_s + i * byte_time_s."""

    first_arrival_s: float
    data: bytes
    read: int = 0


class SimUart:
    """The receiving end of a serial line at ``baud_rate`` (115200 8N1 for IBUS)."""

    def __init__(
        self,
        clock: SimClock,
        baud_rate: int = ibus.BAUD_RATE,
        bits_per_byte: int = BITS_PER_BYTE_8N1,
    ) -> None:
        if baud_rate <= 0 or bits_per_byte <= 0:
            raise ValueError("baud_rate and bits_per_byte must be > 0")
        self._clock = clock
        self.byte_time_s = bits_per_byte / baud_rate
        self._bursts: deque[_Burst] = deque()
        self._line_free_at_s = -math.inf
        self.bytes_sent = 0
        self.bytes_read = 0
        self._arrived_at_s: float | None = None
        self._link = LINK_UP

    def transmit(self, data: bytes, start_s: float | None = None) -> float:
        """Put ``data`` on the line from ``start_s`` (default now) or when the line is free.

        Returns the time the last byte has arrived (when the idle interrupt wakes the clock).
        """
        if not data:
            return max(self._line_free_at_s, self._clock.now())
        begin_s = max(self._clock.now() if start_s is None else start_s, self._line_free_at_s)
        first_arrival_s = begin_s + self.byte_time_s
        last_arrival_s = first_arrival_s + (len(data) - 1) * self.byte_time_s
        self._bursts.append(_Burst(first_arrival_s, bytes(data)))
        self._line_free_at_s = last_arrival_s
        self.bytes_sent += len(data)
        self._clock.call_at(last_arrival_s, self._clock.notify_input)
        return last_arrival_s

    def read_available(self) -> bytes:
        """Every byte whose arrival time has come and that was not read before."""
        now_s = self._clock.now()
        chunks: list[bytes] = []
        newest_at_s: float | None = None
        while self._bursts:
            burst = self._bursts[0]
            arrived = _arrived_count(burst, now_s, self.byte_time_s)
            if arrived > burst.read:
                chunks.append(burst.data[burst.read : arrived])
                burst.read = arrived
                newest_at_s = burst.first_arrival_s + (arrived - 1) * self.byte_time_s
            if burst.read < len(burst.data):
                break
            self._bursts.popleft()
        if self._link.down:
            return b""  # the device is gone: what the line carried meanwhile is lost
        if newest_at_s is not None:
            self._arrived_at_s = newest_at_s
        data = b"".join(chunks)
        self.bytes_read += len(data)
        return data

    @property
    def arrived_at_s(self) -> float | None:
        """When the newest byte read so far arrived (its stop bit's end); None before any."""
        return self._arrived_at_s

    @property
    def link(self) -> LinkState:
        """Down from ``fail()`` to ``restore()``."""
        return self._link

    def fail(self) -> None:
        """Fault injection: the receiving device is gone; bytes arriving meanwhile are lost."""
        self._link = _GONE

    def restore(self) -> None:
        """The device is back: bytes arriving from now on are read (a frame cut in half by the
        loss arrives as its tail, which the IBUS parser drops)."""
        self._link = LINK_UP

    @property
    def line_free_at_s(self) -> float:
        """When the last byte queued so far will have arrived (-inf when nothing was sent)."""
        return self._line_free_at_s


def _arrived_count(burst: _Burst, now_s: float, byte_time_s: float) -> int:
    """How many of the burst's bytes have arrived by ``now_s``."""
    bytes_since_first = (now_s - burst.first_arrival_s) / byte_time_s + _BYTE_SLACK
    if bytes_since_first < 0.0:
        return 0
    return min(len(burst.data), math.floor(bytes_since_first) + 1)
