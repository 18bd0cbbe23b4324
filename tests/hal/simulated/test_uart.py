"""Simulated UART: bytes arrive at 115200 8N1 pace, a mid-frame read gets part of the frame."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.uart import SimUart

BYTE_S = 10 / 115_200
FRAME = bytes(range(32))


def test_a_frame_takes_320_bit_times() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    last_s = uart.transmit(FRAME)
    assert last_s == pytest.approx(32 * 10 / 115_200)
    assert uart.byte_time_s == pytest.approx(BYTE_S)


def test_a_read_mid_frame_returns_only_the_bytes_that_have_arrived() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    uart.transmit(FRAME)
    clock.advance(0.5 * BYTE_S)
    assert uart.read_available() == b""
    clock.advance(10 * BYTE_S)  # 10.5 byte times: ten bytes complete
    assert uart.read_available() == FRAME[:10]
    assert uart.read_available() == b""
    clock.advance(1.0)
    assert uart.read_available() == FRAME[10:]
    assert (uart.bytes_sent, uart.bytes_read) == (32, 32)


def test_the_idle_interrupt_wakes_the_clock_at_the_last_byte() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    uart.transmit(FRAME, start_s=0.001)
    clock.wait_until(1.0)
    assert clock.now() == pytest.approx(0.001 + 32 * BYTE_S)
    assert uart.read_available() == FRAME


def test_a_burst_written_while_the_line_is_busy_queues_behind() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    uart.transmit(FRAME)
    last_s = uart.transmit(b"\xaa\xbb")
    assert last_s == pytest.approx(34 * BYTE_S)
    clock.advance(33 * BYTE_S)
    assert uart.read_available() == FRAME + b"\xaa"
    clock.advance(BYTE_S)
    assert uart.read_available() == b"\xbb"


@given(st.lists(st.floats(0.0, 40 * BYTE_S), max_size=20))
def test_reads_at_any_times_return_the_stream_in_order_without_loss(waits_s: list[float]) -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    uart.transmit(FRAME)
    uart.transmit(FRAME[::-1], start_s=0.01)
    received = b""
    for wait_s in waits_s:
        clock.advance(wait_s)
        chunk = uart.read_available()
        arrived = int(clock.now() / BYTE_S + 1e-9) if clock.now() < 0.01 else None
        if arrived is not None:
            assert len(received + chunk) == min(arrived, 32)
        received += chunk
    clock.advance(1.0)
    received += uart.read_available()
    assert received == FRAME + FRAME[::-1]
