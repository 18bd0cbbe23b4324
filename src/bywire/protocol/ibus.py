"""FlySky IBUS codec: 32-byte receiver frames to raw channel values and back, plus a stream framer.

Frame layout (thesis Table 3), one frame every FRAME_PERIOD_S at BAUD_RATE 8N1::

    byte  0    1    2    3    4    5          28   29   30   31
        +----+----+----+----+----+----+ ... +----+----+----+----+
        |0x20|0x40| ch1 lo hi| ch2 lo hi|     |ch14 lo hi| chk lo hi|
        +----+----+----+----+----+----+ ... +----+----+----+----+
        length cmd  14 channels, uint16 little-endian    checksum
    checksum = 0xFFFF - (byte 0 + byte 1 + ... + byte 29), uint16 little-endian

    ch1 right stick horizontal   ch6 first switch (2 pos)    ch10..ch14 unused (1500)
    ch2 left stick vertical      ch7 third switch (3 pos)
    ch3 right stick vertical     ch8 second switch (3 pos)   sticks 1000..2000, centre 1500
    ch4 left stick horizontal    ch9 fourth switch (2 pos)   switches 1000 / 1500 / 2000
    ch5 unused (1500)

Channel values stay raw uint16: some receivers put failsafe flags in the high nibbles, so
meaning and range checks belong to the RC mapping, not to the codec.
"""

import struct
from collections.abc import Sequence
from dataclasses import dataclass

from bywire.errors import FrameError

FRAME_LENGTH = 32
CHANNEL_COUNT = 14
HEADER = b"\x20\x40"
BAUD_RATE = 115200
"""UART bit rate; 8N1 puts 10 bits on the wire per byte, so a frame takes ~2.8 ms (§4.2.1)."""
BITS_PER_BYTE = 10  # 8N1: a start bit, eight data bits, a stop bit
LINE_FRAME_S = FRAME_LENGTH * BITS_PER_BYTE / BAUD_RATE
"""How long one frame takes on the line (2.78 ms): no receiver sends frames closer together."""
FRAME_PERIOD_S = 0.0077
"""Receiver frame period: §4.2.1 states 7.7 ms and §4.2.2 uses 7.66 ms; Table 1's "~142 Hz"
(7.0 ms) disagrees with both, so the two §4.2 figures win."""

_CHECKED_LENGTH = FRAME_LENGTH - 2
_CHANNELS = struct.Struct(f"<{CHANNEL_COUNT}H")
_CHECKSUM = struct.Struct("<H")
# Skips the header so one unpack yields the channels and the transmitted checksum together.
_BODY = struct.Struct(f"<{len(HEADER)}x{CHANNEL_COUNT + 1}H")
_UINT16_MAX = 0xFFFF


def _checksum_of(frame: bytes | bytearray) -> int:
    # At most 30 * 255 = 7650, so the subtraction never wraps and needs no mask.
    return _UINT16_MAX - sum(frame[:_CHECKED_LENGTH])


def encode_frame(channels: Sequence[int]) -> bytes:
    """Build the 32-byte frame for 14 raw uint16 channel values; FrameError if they do not fit."""
    if len(channels) != CHANNEL_COUNT:
        raise FrameError(f"IBUS frame carries {CHANNEL_COUNT} channels, got {len(channels)}")
    for index, value in enumerate(channels):
        if not 0 <= value <= _UINT16_MAX:
            raise FrameError(f"IBUS channels[{index}] = {value} is outside 0..{_UINT16_MAX}")
    body = HEADER + _CHANNELS.pack(*channels)
    return body + _CHECKSUM.pack(_checksum_of(body))


def decode_frame(frame: bytes | bytearray) -> tuple[int, ...]:
    """Return the 14 raw channels of one frame; FrameError on wrong length, header or checksum."""
    if len(frame) != FRAME_LENGTH:
        raise FrameError(f"IBUS frame must be {FRAME_LENGTH} bytes, got {len(frame)}")
    if frame[: len(HEADER)] != HEADER:
        got = bytes(frame[: len(HEADER)]).hex(" ")
        raise FrameError(f"IBUS header: expected {HEADER.hex(' ')}, got {got}")
    *channels, checksum = _BODY.unpack(frame)
    expected = _checksum_of(frame)
    if checksum != expected:
        raise FrameError(f"IBUS checksum: expected 0x{expected:04X}, got 0x{checksum:04X}")
    return tuple(channels)


@dataclass(frozen=True, slots=True)
class IbusStats:
    """Counters of one IbusParser since it was created (a snapshot; it never changes).

    frames: intact frames yielded. checksum_errors: candidates with the right header but a
    wrong checksum. skipped_bytes: bytes discarded while looking for a frame start.
    resyncs: times the parser locked onto a header after discarding bytes (a realignment);
    a clean stream has none, Figure 16's mid-frame start has one.
    """

    frames: int = 0
    checksum_errors: int = 0
    resyncs: int = 0
    skipped_bytes: int = 0


class IbusParser:
    """Streaming IBUS framer: bytes in, split any way, intact frames out, in stream order.

    Guarantees: a frame is yielded only if its header and checksum are right; every intact frame
    in the stream is yielded, whatever precedes it (garbage, a truncated frame, a stray header,
    a start mid-frame); the counters and the frames do not depend on how the stream was split;
    between feeds at most FRAME_LENGTH - 1 bytes are held. No I/O and no clock: the caller
    passes ``now`` with the bytes.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self._frames = 0
        self._checksum_errors = 0
        self._resyncs = 0
        self._skipped_bytes = 0
        # Set by any discard, cleared when a header is locked on: counts realignments, not bytes.
        self._misaligned = False
        self._last_frame_at: float | None = None

    @property
    def stats(self) -> IbusStats:
        """Snapshot of the counters."""
        return IbusStats(self._frames, self._checksum_errors, self._resyncs, self._skipped_bytes)

    @property
    def checksum_errors(self) -> int:
        """``stats.checksum_errors`` without the snapshot (read on every poll of the loop)."""
        return self._checksum_errors

    @property
    def resyncs(self) -> int:
        """``stats.resyncs`` without the snapshot."""
        return self._resyncs

    @property
    def last_frame_at(self) -> float | None:
        """The ``now`` passed with the bytes that completed the latest frame; None before any.

        A frame completed by a feed without ``now`` sets it back to None, so an unstamped frame
        can never look fresh to an age check.
        """
        return self._last_frame_at

    @property
    def buffered_bytes(self) -> int:
        """Bytes held back as the possible start of a frame; always below FRAME_LENGTH."""
        return len(self._buffer)

    def feed(self, data: bytes | bytearray, now: float | None = None) -> list[tuple[int, ...]]:
        """Take the next bytes of the stream; return the frames they complete, oldest first."""
        self._buffer += data
        frames: list[tuple[int, ...]] = []
        start = self._align(0)
        while start + FRAME_LENGTH <= len(self._buffer):
            channels = self._check(start)
            if channels is None:
                # One byte, not a whole frame: a real frame may begin inside the bad candidate.
                self._skip(1)
                start = self._align(start + 1)
            else:
                frames.append(channels)
                start = self._align(start + FRAME_LENGTH)
        del self._buffer[:start]
        if frames:
            self._last_frame_at = now
        return frames

    def _align(self, start: int) -> int:
        """Return the offset of the next header at or after start, or where to wait for one."""
        found = self._buffer.find(HEADER, start)
        if found < 0:
            # A trailing 0x20 may be the first half of a header still on the wire.
            keep = 1 if len(self._buffer) > start and self._buffer[-1] == HEADER[0] else 0
            found = len(self._buffer) - keep
            self._skip(found - start)
            return found
        self._skip(found - start)
        if self._misaligned:
            self._resyncs += 1
            self._misaligned = False
        return found

    def _check(self, start: int) -> tuple[int, ...] | None:
        """Channels of the candidate at start (header already matched), or None if corrupt."""
        *channels, checksum = _BODY.unpack_from(self._buffer, start)
        if checksum != _checksum_of(self._buffer[start : start + _CHECKED_LENGTH]):
            self._checksum_errors += 1
            return None
        self._frames += 1
        return tuple(channels)

    def _skip(self, count: int) -> None:
        if count > 0:
            self._skipped_bytes += count
            self._misaligned = True
