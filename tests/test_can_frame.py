"""The CAN frame value and the check every port's `send` makes first."""

from __future__ import annotations

import pytest

from bywire.can_frame import MAX_DATA_BYTES, MAX_STANDARD_ID, CanFrame, check_can_frame
from bywire.errors import FrameError


def test_a_classic_standard_frame_passes() -> None:
    check_can_frame(CanFrame(MAX_STANDARD_ID, bytes(MAX_DATA_BYTES)))
    check_can_frame(CanFrame(0, b""))


@pytest.mark.parametrize(
    ("frame", "named"),
    [
        (CanFrame(MAX_STANDARD_ID + 1, b""), "0x800 is not an 11-bit standard id"),
        (CanFrame(-1, b""), "is not an 11-bit standard id"),
        (CanFrame(0x100, bytes(MAX_DATA_BYTES + 1)), "at most 8 data bytes, got 9"),
    ],
)
def test_a_frame_classic_can_cannot_carry_is_refused_naming_why(
    frame: CanFrame, named: str
) -> None:
    with pytest.raises(FrameError, match=named):
        check_can_frame(frame)
