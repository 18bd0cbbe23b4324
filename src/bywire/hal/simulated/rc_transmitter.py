"""Simulated FlySky transmitter and receiver: real IBUS frames on the simulated UART, every period.

The receiver sends a frame every ``period_s`` whether or not anything changed, paced by the UART
at 115200 baud 8N1 (32 bytes take ~2.8 ms). Scenario faults: the link drops (no bytes at all),
the receiver sends its failsafe values (what a FlySky receiver does when the transmitter is out
of range, §5.3), garbage on the line, and frames with a flipped bit (bad checksum).

Garbage is noise on the wire, not a second sender: the receiver keeps its schedule, and a frame
due while the noise is on the line is garbled into it (lost), not sent after it. Queued behind
the noise instead, a receiver whose frames fill the line (a 2.8 ms period) would deliver every
frame up to the noise's length late for seconds (found by `bywire verify --draw-robots 8
--budget 800 --seed 9`, file 5, docs/SAFETY.md row 80).
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence

from bywire.control.rc_mapping import AxisCalibration, RcMapping, SwitchCalibration
from bywire.hal.simulated.timers import PeriodicTimer, SimClock
from bywire.hal.simulated.uart import SimUart
from bywire.model import ControlMode, Gear
from bywire.protocol import ibus

"""Raw values of a switch's low, middle and high position (Table 3)."""
CENTRE_RAW = 1500
_CHECKED_BODY = range(len(ibus.HEADER), ibus.FRAME_LENGTH - 2)  # channel bytes, not header/CRC


def raw_for_axis(norm: float, calibration: AxisCalibration) -> int:
    """The raw value a stick sends for −1…1; the inverse of ``rc_mapping.axis_norm``."""
    norm = min(max(norm, -1.0), 1.0)
    norm = -norm if calibration.reverse else norm
    centre = calibration.center_raw
    span = calibration.max_raw - centre if norm >= 0.0 else centre - calibration.min_raw
    return round(centre + norm * span)


def raw_for_switch(position: int, calibration: SwitchCalibration) -> int:
    """The raw value of the switch's position `position` (0 is its first; reversed if asked),
    the nominal pulse of its calibration; -1 is its last (a light switch's on)."""
    positions = calibration.positions_raw
    index = position % len(positions)
    return positions[len(positions) - 1 - index if calibration.reverse else index]


def idle_channels(mapping: RcMapping) -> tuple[int, ...]:
    """Sticks centred, mode switch at STOP, gear neutral, lights off: a transmitter at rest."""
    channels = [CENTRE_RAW] * ibus.CHANNEL_COUNT
    mode = mapping.mode_positions.index(ControlMode.STOP)
    gear = mapping.gear_positions.index(Gear.NEUTRAL)
    channels[mapping.mode_switch.channel] = raw_for_switch(mode, mapping.mode_switch)
    channels[mapping.gear_switch.channel] = raw_for_switch(gear, mapping.gear_switch)
    channels[mapping.low_beam_switch.channel] = raw_for_switch(0, mapping.low_beam_switch)
    channels[mapping.hazard_switch.channel] = raw_for_switch(0, mapping.hazard_switch)
    return tuple(channels)


IMPLAUSIBLE_RAW = 2300  # µs: above any stick, below the 16-bit field's end


class SimRcTransmitter:
    """The RC link, from the operator's sticks to IBUS bytes on ``uart``."""

    def __init__(
        self,
        clock: SimClock,
        uart: SimUart,
        period_s: float = ibus.FRAME_PERIOD_S,
        *,
        mapping: RcMapping | None = None,
        channels: Sequence[int] | None = None,
        seed: int = 0,
    ) -> None:
        self.mapping = mapping or RcMapping()
        self._uart = uart
        self._channels = list(idle_channels(self.mapping) if channels is None else channels)
        if len(self._channels) != ibus.CHANNEL_COUNT:
            raise ValueError(f"IBUS carries {ibus.CHANNEL_COUNT} channels")
        self._timer = PeriodicTimer(clock, period_s, self._send_frame)
        self._random = random.Random(seed)
        self._failsafe: dict[int, int] | None = None
        self._corrupt_pending = 0
        self._chatter_pending = 0
        self._implausible_pending = 0
        self._dither_pending = 0
        self.dither_raw = 4  # µs either way a dithering mode switch swings
        self.link_up = True
        self.frames_sent = 0
        self.corrupted_frames_sent = 0
        self.frames_lost_to_noise = 0
        self._noise_until_s = -math.inf

    # --- running --------------------------------------------------------------------------------

    def start(self, first_s: float | None = None) -> None:
        """Send a frame every period from ``first_s`` (default now)."""
        self._timer.start(first_s)

    def stop(self) -> None:
        """Receiver switched off."""
        self._timer.stop()

    @property
    def channels(self) -> tuple[int, ...]:
        """The 14 raw values the sticks and switches give now (failsafe not applied)."""
        return tuple(self._channels)

    # --- sticks and switches -----------------------------------------------------------------

    def set_channel(self, index: int, raw: int) -> None:
        """Set one raw channel (0…13)."""
        if not 0 <= index < ibus.CHANNEL_COUNT:
            raise IndexError(f"IBUS channel index {index} is outside 0..{ibus.CHANNEL_COUNT - 1}")
        self._channels[index] = raw

    def set_channels(self, values: Mapping[int, int]) -> None:
        """Set several raw channels at once: ``{index: raw}``."""
        for index, raw in values.items():
            self.set_channel(index, raw)

    def set_steering(self, steering_norm: float) -> None:
        """Right stick horizontal: −1 full left … 1 full right."""
        self.set_channel(
            self.mapping.steering.channel, raw_for_axis(steering_norm, self.mapping.steering)
        )

    def set_pedal(self, pedal_norm: float) -> None:
        """Left stick vertical: 0…1 throttle above centre, −1…0 brake below."""
        axis = self.mapping.throttle_brake
        self.set_channel(axis.channel, raw_for_axis(pedal_norm, axis))

    def set_throttle(self, throttle_norm: float) -> None:
        """Left stick up by ``throttle_norm`` (0…1)."""
        self.set_pedal(max(throttle_norm, 0.0))

    def set_brake(self, brake_norm: float) -> None:
        """Left stick down by ``brake_norm`` (0…1)."""
        self.set_pedal(-max(brake_norm, 0.0))

    def set_mode(self, mode: ControlMode) -> None:
        """Mode switch to STOP, RC or CAN."""
        switch = self.mapping.mode_switch
        self.set_channel(
            switch.channel, raw_for_switch(self.mapping.mode_positions.index(mode), switch)
        )

    def set_gear(self, gear: Gear) -> None:
        """Gear switch to reverse, neutral or forward."""
        switch = self.mapping.gear_switch
        self.set_channel(
            switch.channel, raw_for_switch(self.mapping.gear_positions.index(gear), switch)
        )

    def set_low_beam(self, on: bool) -> None:
        """Low-beam switch."""
        switch = self.mapping.low_beam_switch
        self.set_channel(switch.channel, raw_for_switch(-1 if on else 0, switch))

    def set_hazard(self, on: bool) -> None:
        """Hazard switch."""
        switch = self.mapping.hazard_switch
        self.set_channel(switch.channel, raw_for_switch(-1 if on else 0, switch))

    # --- faults ----------------------------------------------------------------------------------

    def link_lost(self) -> None:
        """Radio link gone and the receiver silent: no bytes at all."""
        self.link_up = False

    def link_restored(self) -> None:
        """Frames again, from the next period."""
        self.link_up = True

    def failsafe(self, values: Mapping[int, int]) -> None:
        """Receiver in failsafe: these channels carry their failsafe values, the rest hold."""
        for index in values:
            if not 0 <= index < ibus.CHANNEL_COUNT:
                raise IndexError(f"IBUS channel index {index} is outside 0..13")
        self._failsafe = dict(values)

    def failsafe_off(self) -> None:
        """Transmitter back in range: the sticks count again."""
        self._failsafe = None

    @property
    def in_failsafe(self) -> bool:
        """True while failsafe values are being sent."""
        return self._failsafe is not None

    def inject_bytes(self, data: bytes) -> None:
        """Noise: ``data`` on the line now (after any frame already on it); the frames due
        before it has passed are lost in it, the later ones go out on time."""
        self._noise_until_s = self._uart.transmit(data)  # behind all on the line: the latest

    def corrupt_next_frames(self, count: int) -> None:
        """Flip one bit in the channel bytes of each of the next ``count`` frames."""
        self._corrupt_pending += count

    def chatter_next_frames(self, count: int) -> None:
        """A bouncing mode switch: of the next ``count`` frames, every other one reads STOP
        (the last one does, so an odd count starts with one), the others the position it is
        set to."""
        self._chatter_pending = count

    def set_mode_raw(self, raw: int) -> None:
        """The mode switch's raw pulse, wherever it is (a switch with other travel, or between
        two positions)."""
        self.set_channel(self.mapping.mode_switch.channel, raw)

    def dither_next_frames(self, count: int) -> None:
        """A mode switch (or a knob on its channel) that dithers: the next ``count`` frames carry
        its pulse ±`dither_raw` µs, alternately."""
        self._dither_pending = count

    def implausible_next_frames(self, count: int) -> None:
        """The next ``count`` frames carry an intact checksum but a steering pulse of 2300 µs,
        outside what any stick gives (a receiver glitch)."""
        self._implausible_pending = count

    # --- the receiver's frame ----------------------------------------------------------------

    def _send_frame(self, tick_s: float) -> None:
        if not self.link_up:
            return
        if tick_s < self._noise_until_s:
            self.frames_lost_to_noise += 1
            return
        channels = list(self._channels)
        for index, raw in (self._failsafe or {}).items():
            channels[index] = raw
        if self._chatter_pending > 0:
            if self._chatter_pending % 2 == 1:
                switch = self.mapping.mode_switch
                stop = self.mapping.mode_positions.index(ControlMode.STOP)
                channels[switch.channel] = raw_for_switch(stop, switch)
            self._chatter_pending -= 1
        if self._dither_pending > 0:
            sign = 1 if self._dither_pending % 2 else -1
            channels[self.mapping.mode_switch.channel] += sign * self.dither_raw
            self._dither_pending -= 1
        if self._implausible_pending > 0:
            self._implausible_pending -= 1
            channels[self.mapping.steering.channel] = IMPLAUSIBLE_RAW
        frame = bytearray(ibus.encode_frame(channels))
        if self._corrupt_pending > 0:
            self._corrupt_pending -= 1
            self.corrupted_frames_sent += 1
            frame[self._random.choice(_CHECKED_BODY)] ^= 1 << self._random.randrange(8)
        self.frames_sent += 1
        self._uart.transmit(bytes(frame), start_s=tick_s)
