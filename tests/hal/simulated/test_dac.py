"""Simulated DAC6574: decodes the real I2C frames, refuses malformed ones, injects NAKs."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.errors import HardwareError
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.dac import SimDac6574
from bywire.protocol import dac6574


@given(st.integers(0, 3), st.integers(0, 1023))
def test_a_real_write_frame_sets_the_channel(channel: int, code: int) -> None:
    dac = SimDac6574(VirtualClock())
    dac.write(dac6574.encode_write(channel, code))
    assert dac.code(channel) == code
    assert dac.volts(channel) == pytest.approx(5.0 * code / 1024)
    assert all(dac.volts(other) == 0.0 for other in range(4) if other != channel)


def test_history_keeps_first_write_and_changes_per_channel() -> None:
    clock = VirtualClock()
    dac = SimDac6574(clock)
    dac.write(dac6574.encode_write(0, 0))
    dac.write(dac6574.encode_write(1, 0))
    clock.advance(0.01)
    dac.write(dac6574.encode_write(0, 0))
    dac.write(dac6574.encode_write(0, 512))
    assert dac.history == [(0.0, 0, 0.0), (0.0, 1, 0.0), (0.01, 0, 2.5)]
    assert dac.writes == 4


def test_power_down_drives_zero_volts_and_keeps_the_code() -> None:
    dac = SimDac6574(VirtualClock())
    dac.write(dac6574.encode_write(2, 800))
    dac.write(dac6574.encode_power_down(2, dac6574.PowerDownMode.PULLDOWN_1K))
    assert dac.volts(2) == 0.0
    assert dac.code(2) == 800
    assert dac.powered_down(2)


@pytest.mark.parametrize(
    "frame",
    [
        b"",
        b"\x10\x80",
        b"\x10\x80\x00\x00",
        b"\x00\x80\x00",  # load bits 00
        b"\x18\x80\x00",  # don't-care bit X set
        b"\x10\x80\x01",  # LS byte low bits set
        b"\x50\x80\x00",  # extended address A2 = 1
    ],
)
def test_a_malformed_frame_is_not_acknowledged(frame: bytes) -> None:
    dac = SimDac6574(VirtualClock())
    with pytest.raises(HardwareError, match="not acknowledged"):
        dac.write(frame)
    assert dac.malformed_frames == 1
    assert dac.writes == 0
    assert dac.history == []


def test_failing_until_a_time_raises_and_counts_then_recovers() -> None:
    clock = VirtualClock()
    dac = SimDac6574(clock)
    dac.fail_writes(until_s=0.1)
    for _ in range(3):
        with pytest.raises(HardwareError):
            dac.write(dac6574.encode_write(0, 100))
        clock.advance(0.04)
    assert dac.failed_writes == 3
    assert dac.code(0) == 0
    dac.write(dac6574.encode_write(0, 100))
    assert dac.code(0) == 100


def test_failing_for_a_count_of_writes() -> None:
    dac = SimDac6574(VirtualClock())
    dac.fail_writes(count=2)
    outcomes = []
    for code in (1, 2, 3):
        try:
            dac.write(dac6574.encode_write(0, code))
            outcomes.append(True)
        except HardwareError:
            outcomes.append(False)
    assert outcomes == [False, False, True]
    assert (dac.failed_writes, dac.code(0)) == (2, 3)


def test_failing_forever_until_stopped() -> None:
    clock = VirtualClock()
    dac = SimDac6574(clock)
    dac.fail_writes()
    clock.advance(3600.0)
    with pytest.raises(HardwareError, match="no acknowledge"):
        dac.write(dac6574.encode_write(1, 5))
    dac.stop_failing()
    dac.write(dac6574.encode_write(1, 5))
    assert dac.code(1) == 5


def test_history_limit_bounds_a_long_run() -> None:
    clock = VirtualClock()
    dac = SimDac6574(clock, history_limit=50)
    for code in range(1000):
        clock.advance(0.01)
        dac.write(dac6574.encode_write(0, code))
    assert 50 <= len(dac.history) < 100
    time_s, channel, volts = dac.history[-1]
    assert time_s == pytest.approx(10.0)
    assert (channel, volts) == (0, 5.0 * 999 / 1024)
