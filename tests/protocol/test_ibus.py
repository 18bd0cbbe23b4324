"""Tests of the IBUS codec and stream framer against Table 3, Figure 16 and arbitrary streams."""

from itertools import pairwise

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from bywire.errors import FrameError
from bywire.protocol.ibus import (
    BAUD_RATE,
    CHANNEL_COUNT,
    FRAME_LENGTH,
    FRAME_PERIOD_S,
    HEADER,
    IbusParser,
    IbusStats,
    decode_frame,
    encode_frame,
)

# Golden frames written by hand from Table 3; checksum = 0xFFFF - sum of bytes 0..29.
# All 1500 (0x05DC): 0x20 + 0x40 + 14 * (0xDC + 0x05) = 3246 = 0x0CAE -> 0xF351.
CENTRED = bytes.fromhex("2040" + "dc05" * 14 + "51f3")
CENTRED_CHANNELS = (1500,) * 14
# Sticks 1000, 2000, 1250, 1750; unused 1500; switches 2000, 1000, 1500, 1000; unused 1500 x5.
# 96 + 235 + 215 + 230 + 220 + 225 + 215 + 235 + 225 + 235 + 5 * 225 = 3256 = 0x0CB8 -> 0xF347.
STICKS = bytes.fromhex("2040 e803 d007 e204 d606 dc05 d007 e803 dc05 e803" + "dc05" * 5 + "47f3")
STICKS_CHANNELS = (1000, 2000, 1250, 1750, 1500, 2000, 1000, 1500, 1000) + (1500,) * 5
# Raw extremes and a failsafe-style high nibble (0xF5DC) must pass untouched.
# 96 + (0 + 0) + (255 + 255) + (0x34 + 0x12) + (0xDC + 0xF5) = 1141 = 0x0475 -> 0xFB8A.
RAW = bytes.fromhex("2040 0000 ffff 3412 dcf5" + "0000" * 10 + "8afb")
RAW_CHANNELS = (0, 0xFFFF, 0x1234, 0xF5DC) + (0,) * 10
GOLDEN = [(CENTRED, CENTRED_CHANNELS), (STICKS, STICKS_CHANNELS), (RAW, RAW_CHANNELS)]

channel_values = st.lists(st.integers(0, 0xFFFF), min_size=CHANNEL_COUNT, max_size=CHANNEL_COUNT)
frames = channel_values.map(encode_frame)


def feed_all(parser: IbusParser, chunks: list[bytes]) -> list[tuple[int, ...]]:
    return [channels for chunk in chunks for channels in parser.feed(chunk)]


def split(stream: bytes, cuts: list[int]) -> list[bytes]:
    edges = [0, *sorted(set(cuts)), len(stream)]
    return [stream[start:end] for start, end in pairwise(edges)]


def valid_frame_offsets(stream: bytes) -> list[int]:
    offsets = []
    for offset in range(len(stream) - FRAME_LENGTH + 1):
        try:
            decode_frame(stream[offset : offset + FRAME_LENGTH])
        except FrameError:
            continue
        offsets.append(offset)
    return offsets


def test_constants_match_table_3_and_section_4_2_1() -> None:
    assert (FRAME_LENGTH, CHANNEL_COUNT, HEADER) == (32, 14, b"\x20\x40")
    frame_airtime_s = FRAME_LENGTH * 10 / BAUD_RATE
    assert frame_airtime_s == pytest.approx(0.00278, abs=1e-5)
    assert frame_airtime_s < 0.0076 <= FRAME_PERIOD_S <= 0.0078


@pytest.mark.parametrize(("frame", "channels"), GOLDEN)
def test_golden_frame_decodes_to_its_channels(frame: bytes, channels: tuple[int, ...]) -> None:
    assert decode_frame(frame) == channels


@pytest.mark.parametrize(("frame", "channels"), GOLDEN)
def test_encode_reproduces_golden_bytes(frame: bytes, channels: tuple[int, ...]) -> None:
    assert encode_frame(channels) == frame


@given(channel_values)
def test_round_trip_keeps_raw_values(channels: list[int]) -> None:
    frame = encode_frame(channels)
    assert len(frame) == FRAME_LENGTH
    assert decode_frame(frame) == tuple(channels)


@pytest.mark.parametrize("count", [0, 13, 15])
def test_encode_rejects_wrong_channel_count(count: int) -> None:
    with pytest.raises(FrameError, match=f"14 channels, got {count}"):
        encode_frame([1500] * count)


@pytest.mark.parametrize("value", [-1, 0x10000])
def test_encode_rejects_value_outside_uint16(value: int) -> None:
    channels = [1500] * CHANNEL_COUNT
    channels[3] = value
    with pytest.raises(ValueError, match=rf"channels\[3\] = {value} is outside"):
        encode_frame(channels)


@pytest.mark.parametrize("length", [0, 1, 31, 33, 64])
def test_decode_rejects_wrong_length(length: int) -> None:
    frame = (CENTRED * 2)[:length]
    with pytest.raises(FrameError, match=f"32 bytes, got {length}") as caught:
        decode_frame(frame)
    assert isinstance(caught.value, ValueError)


def test_decode_rejects_wrong_header() -> None:
    frame = b"\x20\x41" + CENTRED[2:]
    with pytest.raises(FrameError, match="header: expected 20 40, got 20 41") as caught:
        decode_frame(frame)
    assert isinstance(caught.value, ValueError)


def test_decode_rejects_bad_checksum() -> None:
    frame = CENTRED[:30] + b"\x50\xf3"
    with pytest.raises(FrameError, match="checksum: expected 0xF351, got 0xF350") as caught:
        decode_frame(frame)
    assert isinstance(caught.value, ValueError)


@pytest.mark.parametrize("mask", [0x01, 0xFF])
@pytest.mark.parametrize("position", range(FRAME_LENGTH))
@pytest.mark.parametrize(("frame", "channels"), GOLDEN)
def test_every_one_byte_corruption_is_rejected(
    frame: bytes, channels: tuple[int, ...], position: int, mask: int
) -> None:
    corrupt = bytearray(frame)
    corrupt[position] ^= mask
    with pytest.raises(FrameError):
        decode_frame(bytes(corrupt))
    parser = IbusParser()
    assert parser.feed(bytes(corrupt)) == []
    assert parser.feed(frame) == [channels]
    assert parser.stats.frames == 1


def test_figure_16_misalignment_resynchronises() -> None:
    # The DMA buffer of Figure 16: the last 10 bytes of one frame, then the next frame's start.
    dma_buffer = bytes([220, 5, 220, 5, 220, 5, 220, 5, 51, 243]) + CENTRED[:22]
    parser = IbusParser()
    assert parser.feed(dma_buffer) == []
    assert parser.feed(CENTRED[22:] + STICKS) == [CENTRED_CHANNELS, STICKS_CHANNELS]
    assert parser.stats == IbusStats(frames=2, checksum_errors=0, resyncs=1, skipped_bytes=10)


# A false header costs one realignment to reach it and one to leave it.
@pytest.mark.parametrize(
    ("stray", "resyncs"),
    [(b"\x20", 1), (b"\x20\x40", 1), (b"\x20\x40\x20", 1), (b"\x20\x20\x40", 2)],
)
@pytest.mark.parametrize("read_size", [1, 2, 7, 100])
def test_stray_header_bytes_before_a_frame(stray: bytes, resyncs: int, read_size: int) -> None:
    stream = stray + STICKS + CENTRED
    chunks = [stream[i : i + read_size] for i in range(0, len(stream), read_size)]
    parser = IbusParser()
    assert feed_all(parser, chunks) == [STICKS_CHANNELS, CENTRED_CHANNELS]
    assert parser.stats.resyncs == resyncs


@pytest.mark.parametrize("kept", range(1, FRAME_LENGTH))
def test_truncated_frame_then_full_frame(kept: int) -> None:
    parser = IbusParser()
    assert parser.feed(STICKS[:kept]) == []
    assert parser.feed(CENTRED) == [CENTRED_CHANNELS]
    assert parser.stats.frames == 1


def test_frames_fed_one_byte_at_a_time() -> None:
    stream = CENTRED + STICKS + RAW
    parser = IbusParser()
    assert feed_all(parser, [bytes([byte]) for byte in stream]) == [c for _, c in GOLDEN]
    assert parser.stats == IbusStats(frames=3)


def test_frame_is_yielded_by_the_feed_that_completes_it() -> None:
    parser = IbusParser()
    assert parser.feed(CENTRED[:31]) == []
    assert parser.feed(CENTRED[31:]) == [CENTRED_CHANNELS]


def test_last_frame_at_is_now_of_the_completing_feed() -> None:
    parser = IbusParser()
    assert parser.last_frame_at is None
    parser.feed(CENTRED[:20], now=1.0)
    assert parser.last_frame_at is None
    parser.feed(CENTRED[20:] + b"\x00\x01", now=2.5)
    assert parser.last_frame_at == 2.5
    parser.feed(STICKS[:5], now=3.0)
    assert parser.last_frame_at == 2.5
    parser.feed(STICKS[5:], now=4.0)
    assert parser.last_frame_at == 4.0


def test_frame_without_now_clears_last_frame_at() -> None:
    parser = IbusParser()
    parser.feed(CENTRED, now=1.0)
    parser.feed(CENTRED)
    assert parser.last_frame_at is None


def test_checksum_error_is_counted_and_next_frame_kept() -> None:
    parser = IbusParser()
    bad = CENTRED[:30] + b"\x00\x00"
    assert parser.feed(bad + STICKS) == [STICKS_CHANNELS]
    assert parser.stats == IbusStats(frames=1, checksum_errors=1, resyncs=1, skipped_bytes=32)


@pytest.mark.parametrize("pattern", [b"\x00", b"\x20", b"\x20\x40", b"\x20\x40\x20", b"\xaa\x20"])
def test_buffer_stays_bounded_on_garbage(pattern: bytes) -> None:
    parser = IbusParser()
    garbage = pattern * (100_000 // len(pattern))
    for start in range(0, len(garbage), 4096):
        assert parser.feed(garbage[start : start + 4096]) == []
        assert parser.buffered_bytes < FRAME_LENGTH
    assert parser.feed(CENTRED) == [CENTRED_CHANNELS]


def test_long_noisy_stream_in_uart_sized_reads_loses_no_frame() -> None:
    # 10 000 frames is ~77 s of receiver traffic; parsing speed is measured in bench/, not here.
    stream = (CENTRED + b"\x20" + STICKS + b"\x20\x40\x00") * 5_000
    parser = IbusParser()
    count = sum(len(parser.feed(stream[i : i + 64])) for i in range(0, len(stream), 64))
    assert count == 10_000
    assert parser.stats.frames == 10_000


garbage_chunks = st.one_of(
    st.binary(max_size=40),
    st.lists(st.sampled_from([0x20, 0x40]), max_size=8).map(bytes),
    st.tuples(frames, st.integers(1, FRAME_LENGTH - 1)).map(lambda pair: pair[0][: pair[1]]),
)
pieces = st.lists(
    st.one_of(frames.map(lambda f: (True, f)), garbage_chunks.map(lambda g: (False, g)))
)


def planted_stream(parts: list[tuple[bool, bytes]]) -> tuple[bytes, list[int]]:
    stream, offsets = b"", []
    for is_frame, chunk in parts:
        if is_frame:
            offsets.append(len(stream))
        stream += chunk
    return stream, offsets


@settings(max_examples=300)
@given(pieces, st.data())
def test_stream_yields_exactly_the_intact_frames(
    parts: list[tuple[bool, bytes]], data: st.DataObject
) -> None:
    stream, offsets = planted_stream(parts)
    # Garbage may, by chance, complete a checksum (alone or with a neighbour's bytes): skip those.
    assume(valid_frame_offsets(stream) == offsets)
    cuts = data.draw(st.lists(st.integers(0, len(stream))))
    parser = IbusParser()
    yielded = feed_all(parser, split(stream, cuts))
    assert yielded == [decode_frame(stream[o : o + FRAME_LENGTH]) for o in offsets]
    assert parser.stats.frames == len(yielded)
    assert parser.buffered_bytes < FRAME_LENGTH


@given(pieces, st.data())
def test_split_does_not_change_frames_or_counters(
    parts: list[tuple[bool, bytes]], data: st.DataObject
) -> None:
    stream, _ = planted_stream(parts)
    whole, pieces_parser = IbusParser(), IbusParser()
    cuts = data.draw(st.lists(st.integers(0, len(stream))))
    assert whole.feed(stream) == feed_all(pieces_parser, split(stream, cuts))
    assert whole.stats == pieces_parser.stats
    assert whole.buffered_bytes == pieces_parser.buffered_bytes


@given(pieces, st.data())
def test_every_yielded_frame_is_intact_in_the_stream(
    parts: list[tuple[bool, bytes]], data: st.DataObject
) -> None:
    stream = bytearray(planted_stream(parts)[0])
    for position in data.draw(st.lists(st.integers(0, max(len(stream) - 1, 0)), max_size=8)):
        if stream:
            stream[position] ^= data.draw(st.integers(1, 0xFF))
    cuts = data.draw(st.lists(st.integers(0, len(stream))))
    parser = IbusParser()
    yielded = feed_all(parser, split(bytes(stream), cuts))
    assert all(encode_frame(channels) in stream for channels in yielded)
    assert parser.stats.frames == len(yielded)
