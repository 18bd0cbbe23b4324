"""A classic CAN data frame: the value every CAN port, codec and session passes around.

It sits below the hardware seam (`hal.ports`, whose ports send and receive it) so that the codecs
and the SecOC sessions above the protocol layer can speak of frames without reaching up into
the hardware layer.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.errors import FrameError

MAX_STANDARD_ID = 0x7FF
MAX_DATA_BYTES = 8


@dataclass(frozen=True, slots=True)
class CanFrame:
    """One classic CAN data frame with an 11-bit id, stamped with the clock's time on arrival."""

    arbitration_id: int
    data: bytes
    timestamp_s: float = 0.0

    # written out, as the dataclass would make it: compiled, mypyc makes it stores into the
    # struct (the dataclass's own is interpreted Python); the frame of every CAN message
    def __init__(self, arbitration_id: int, data: bytes, timestamp_s: float = 0.0) -> None:
        object.__setattr__(self, "arbitration_id", arbitration_id)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "timestamp_s", timestamp_s)


def check_can_frame(frame: CanFrame) -> None:
    """FrameError for a frame classic CAN cannot carry; every `CanPort.send` checks this first."""
    if not 0 <= frame.arbitration_id <= MAX_STANDARD_ID:
        raise FrameError(f"CAN id 0x{frame.arbitration_id:X} is not an 11-bit standard id")
    if len(frame.data) > MAX_DATA_BYTES:
        raise FrameError(f"classic CAN carries at most 8 data bytes, got {len(frame.data)}")
