"""Simulated TI DAC6574: decodes every real I2C frame, keeps each channel's output, injects NAKs.

A malformed frame raises HardwareError, as the real chip's missing acknowledge would make the
I2C driver do, so a controller bug that builds a bad frame shows up as a failed write.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from bywire.errors import FrameError, HardwareError
from bywire.hal.simulated.timers import SimClock
from bywire.protocol import dac6574


@dataclass(slots=True)
class DacChannel:
    """One output: the register's code, whether it is powered down, and the volts it drives."""

    code: int = 0
    powered_down: bool = False
    volts: float = 0.0
    written: bool = False


class SimDac6574:
    """An ``I2cDevice`` answering like a DAC6574 at Vref (5 V on the robot)."""

    def __init__(
        self,
        clock: SimClock,
        vref_volts: float = dac6574.DEFAULT_VREF_VOLTS,
        extended_address: int = 0,
        history_limit: int | None = 100_000,
    ) -> None:
        self._clock = clock
        self._history_limit = history_limit
        self._vref_volts = vref_volts
        self._extended_address = extended_address
        self._channels = [DacChannel() for _ in dac6574.CHANNELS]
        self.history: list[tuple[float, int, float]] = []
        """``(time_s, channel, volts)`` for the first write of a channel and every change; at
        least the latest ``history_limit`` entries are kept (None: all)."""
        self.writes = 0
        self.failed_writes = 0
        self.malformed_frames = 0
        self._fail_until_s: float | None = None
        self._fail_count = 0
        self._fail_pattern: tuple[bool, ...] = ()
        self._pattern_index = 0
        self._stall_next_s: float | None = None
        self._slow_s: float | None = None  # every write takes this long (`slow_writes`)
        self.on_stall: Callable[[float], None] | None = None
        """Called with the stall's length when a stalled write begins (the world lets the
        simulated time run meanwhile); the write lands when it returns, as an I2C write lands
        at its last acknowledge."""

    def write(self, data: bytes) -> None:
        stall_s = self._slow_s
        if self._stall_next_s is not None:
            stall_s, self._stall_next_s = self._stall_next_s, None
        if stall_s is not None and self.on_stall is not None:
            self.on_stall(stall_s)
        if self._failing():
            self.failed_writes += 1
            raise HardwareError("DAC6574: no acknowledge (simulated bus fault)")
        try:
            frame = dac6574.decode_frame(data)
        except FrameError as error:
            self.malformed_frames += 1
            raise HardwareError(f"DAC6574: frame not acknowledged: {error}") from error
        if frame.extended_address != self._extended_address:
            self.malformed_frames += 1
            raise HardwareError(
                f"DAC6574: extended address {frame.extended_address} is not "
                f"{self._extended_address}; frame not acknowledged"
            )
        self.writes += 1
        if isinstance(frame, dac6574.Write):
            self._update(frame.channel, frame.code, powered_down=False)
        else:
            self._update(frame.channel, self._channels[frame.channel].code, powered_down=True)

    def volts(self, channel: int) -> float:
        """The voltage channel 0…3 drives now (0 V when powered down or never written)."""
        return self._channels[channel].volts

    def code(self, channel: int) -> int:
        """The 10-bit code in the channel's register."""
        return self._channels[channel].code

    def powered_down(self, channel: int) -> bool:
        """True when the channel was powered down and not written since."""
        return self._channels[channel].powered_down

    def fail_writes(self, until_s: float | None = None, count: int | None = None) -> None:
        """Make writes fail: until ``until_s``, for the next ``count`` writes, or (neither) until
        ``stop_failing()``. Each failed write raises HardwareError and is counted."""
        if count is not None and count < 0:
            raise ValueError(f"count must be >= 0, got {count}")
        if until_s is None and count is None:
            until_s = math.inf
        self._fail_until_s = until_s
        self._fail_count = count or 0

    def fail_pattern(self, pattern: tuple[bool, ...]) -> None:
        """Fail writes by a repeating pattern (True: NAK), e.g. (True, False) for every other
        one, from the next write until ``stop_failing()``."""
        if not pattern:
            raise ValueError("a failure pattern needs at least one entry")
        self._fail_pattern, self._pattern_index = tuple(pattern), 0

    def stop_failing(self) -> None:
        """Acknowledge writes again, at full speed."""
        self._fail_until_s = None
        self._fail_count = 0
        self._fail_pattern = ()
        self._slow_s = None

    def slow_writes(self, transfer_s: float) -> None:
        """Every write from now on takes `transfer_s` before it lands, and succeeds (a slave
        stretching the clock, a bus shared with a slow device) until ``stop_failing()``."""
        if not transfer_s >= 0.0:
            raise ValueError(f"transfer_s must be >= 0, got {transfer_s}")
        self._slow_s = transfer_s

    def stall_next_write(self, stall_s: float) -> None:
        """The next write hangs inside the driver for ``stall_s`` before it lands."""
        if not stall_s >= 0.0:
            raise ValueError(f"stall_s must be >= 0, got {stall_s}")
        self._stall_next_s = stall_s

    def _failing(self) -> bool:
        if self._fail_count > 0:
            self._fail_count -= 1
            return True
        if self._fail_pattern:
            failing = self._fail_pattern[self._pattern_index % len(self._fail_pattern)]
            self._pattern_index += 1
            return failing
        return self._fail_until_s is not None and self._clock.now() < self._fail_until_s

    def _update(self, channel: int, code: int, powered_down: bool) -> None:
        state = self._channels[channel]
        volts = 0.0 if powered_down else dac6574.volts_from_code(code, self._vref_volts)
        if volts != state.volts or not state.written:
            self.history.append((self._clock.now(), channel, volts))
            limit = self._history_limit
            if limit is not None and len(self.history) >= 2 * limit:
                del self.history[: len(self.history) - limit]  # in batches: O(1) on average
        state.code, state.powered_down, state.volts = code, powered_down, volts
        state.written = True
