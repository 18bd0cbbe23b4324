"""Captures across a pipe: the one format between the controller and its writer process.

A batch of captures is one frame: its length (4 bytes, little-endian) and a `marshal` dump of
`[(tag, fields), ...]`, where `fields` is the capture as a plain tuple. `marshal` is the
interpreter's own serialiser of plain values, written in C: a batch of a state capture and a few
CAN frames costs ~4 µs to dump, where encoding the state's message costs ~80 µs of interpreter
time. Its format 2 keeps no table of shared objects, which halves the cost against the default
(captures share nothing worth it). The writer process runs the same Python (`sys.executable`).
Pure functions, no I/O.
"""

from __future__ import annotations

import marshal
import struct
from collections.abc import Iterable

from bywire.telemetry.capture import (
    CanCapture,
    Capture,
    EventCapture,
    PoseCapture,
    StateCapture,
)

_LENGTH = struct.Struct("<I")
HEADER_BYTES = _LENGTH.size
MAX_FRAME_BYTES = 64 * 1024 * 1024  # far above any batch; a longer length is a corrupt stream
MARSHAL_FORMAT = 2  # floats in binary, no back-references (format 3 added them, at a cost)

_KINDS: tuple[type[StateCapture | EventCapture | CanCapture | PoseCapture], ...] = (
    StateCapture,
    EventCapture,
    CanCapture,
    PoseCapture,
)
_TAGS = {kind: tag for tag, kind in enumerate(_KINDS)}


class WireError(ValueError):
    """The stream is not a sequence of frames this module wrote."""


def pack(captures: Iterable[Capture]) -> bytes:
    """One frame holding `captures`, in order."""
    tags = _TAGS
    payload = marshal.dumps(
        [(tags[type(capture)], tuple(capture)) for capture in captures], MARSHAL_FORMAT
    )
    return _LENGTH.pack(len(payload)) + payload


def frame_length(header: bytes) -> int:
    """The payload's length announced by a frame's first `HEADER_BYTES` bytes."""
    length: int = _LENGTH.unpack(header)[0]
    if length > MAX_FRAME_BYTES:
        raise WireError(f"frame of {length} bytes announced, more than {MAX_FRAME_BYTES}")
    return length


def split(buffer: bytearray) -> list[bytes]:
    """The payloads of the whole frames at the start of `buffer`, removed from it; a frame not
    yet complete stays for the next bytes to finish."""
    payloads = []
    start = 0
    while len(buffer) - start >= HEADER_BYTES:
        end = start + HEADER_BYTES + frame_length(bytes(buffer[start : start + HEADER_BYTES]))
        if end > len(buffer):
            break
        payloads.append(bytes(buffer[start + HEADER_BYTES : end]))
        start = end
    del buffer[:start]
    return payloads


def unpack(payload: bytes) -> list[Capture]:
    """The captures of one frame's payload (the bytes after its header)."""
    try:
        items = marshal.loads(payload)
        return [_KINDS[tag](*fields) for tag, fields in items]
    except (EOFError, ValueError, TypeError, IndexError) as error:
        raise WireError(f"not a frame of captures: {error}") from None
