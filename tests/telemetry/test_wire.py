"""The pipe's format: every capture of a run crosses it unchanged; a corrupt stream is refused."""

from __future__ import annotations

import pytest

from bywire.telemetry.capture import CanCapture, Capture, EventCapture, StateCapture
from bywire.telemetry.wire import (
    HEADER_BYTES,
    MAX_FRAME_BYTES,
    WireError,
    frame_length,
    pack,
    split,
    unpack,
)


def test_every_capture_of_a_run_crosses_unchanged_and_in_order(captures: list[Capture]) -> None:
    assert {type(c) for c in captures} == {StateCapture, EventCapture, CanCapture}
    frame = pack(captures)
    assert frame_length(frame[:HEADER_BYTES]) == len(frame) - HEADER_BYTES
    back = unpack(frame[HEADER_BYTES:])
    assert back == captures
    assert [type(c) for c in back] == [type(c) for c in captures]


def test_an_empty_batch_is_a_frame_too() -> None:
    frame = pack([])
    assert unpack(frame[HEADER_BYTES:]) == []


@pytest.mark.parametrize(
    "payload",
    [b"", b"\x00garbage", pack([CanCapture(1.0, 0x100, b"\x01", "")])[HEADER_BYTES:-3]],
    ids=["empty", "not-marshal", "cut-short"],
)
def test_a_payload_that_is_not_captures_is_refused(payload: bytes) -> None:
    with pytest.raises(WireError, match="not a frame of captures"):
        unpack(payload)


def test_a_length_beyond_any_batch_is_refused_before_reading_it() -> None:
    with pytest.raises(WireError, match=str(MAX_FRAME_BYTES)):
        frame_length((MAX_FRAME_BYTES + 1).to_bytes(HEADER_BYTES, "little"))


def test_a_stream_splits_into_whole_frames_and_keeps_the_rest_for_later(
    captures: list[Capture],
) -> None:
    """The writer's process reads what the pipe holds: frames arrive cut anywhere."""
    frames = [pack(captures[k : k + 7]) for k in range(0, len(captures), 7)]
    stream = b"".join(frames)
    buffer = bytearray()
    back: list[Capture] = []
    for start in range(0, len(stream), 1000):  # 1000-byte reads, across frame boundaries
        buffer += stream[start : start + 1000]
        for payload in split(buffer):
            back += unpack(payload)
    assert buffer == bytearray()
    assert back == captures
