"""DAC6574 frames: golden bytes from the datasheet bit layout, round trips, clamps, errors."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.errors import ConfigError, FrameError
from bywire.protocol import dac6574
from bywire.protocol.dac6574 import PowerDown, PowerDownMode, Write

# Control byte A3 A2 L1 L0 X Sel1 Sel0 PD0 with L1 L0 = 01 (write and update), PD0 = 0.
CONTROL_BY_CHANNEL = {0: 0b0001_0000, 1: 0b0001_0010, 2: 0b0001_0100, 3: 0b0001_0110}
# MS byte D9..D2, LS byte D1 D0 0 0 0 0 0 0.
DATA_BY_CODE = {
    0: (0b0000_0000, 0b0000_0000),
    1: (0b0000_0000, 0b0100_0000),
    512: (0b1000_0000, 0b0000_0000),
    1023: (0b1111_1111, 0b1100_0000),
}
GOLDEN_WRITES = [
    (channel, code, bytes((control, *DATA_BY_CODE[code])))
    for (channel, control), code in itertools.product(CONTROL_BY_CHANNEL.items(), DATA_BY_CODE)
]


@pytest.mark.parametrize(("channel", "code", "frame"), GOLDEN_WRITES)
def test_write_frame_matches_the_datasheet_layout(channel: int, code: int, frame: bytes) -> None:
    assert dac6574.encode_write(channel, code) == frame
    assert dac6574.decode_write(frame) == (channel, code)


def test_every_channel_and_code_round_trips() -> None:
    for channel, code in itertools.product(range(4), range(1024)):
        frame = dac6574.encode_write(channel, code)
        assert len(frame) == 3
        assert dac6574.decode_write(frame) == (channel, code)
        assert dac6574.decode_frame(frame) == Write(channel, code)


def test_extended_address_bits_are_the_control_bytes_top_bits() -> None:
    frame = dac6574.encode_write(3, 1023, extended_address=0b10)
    assert frame == bytes((0b1001_0110, 0b1111_1111, 0b1100_0000))
    assert dac6574.decode_write(frame, extended_address=0b10) == (3, 1023)
    with pytest.raises(FrameError, match="A3 A2"):
        dac6574.decode_write(frame)


# Power down: control PD0 = 1; MS byte PD1 PD0 0 0 0 0 0 0; LS byte 0.
@pytest.mark.parametrize(
    ("mode", "mode_byte"),
    [
        (PowerDownMode.PULLDOWN_1K, 0b0100_0000),
        (PowerDownMode.PULLDOWN_100K, 0b1000_0000),
        (PowerDownMode.HIGH_IMPEDANCE, 0b1100_0000),
    ],
)
@pytest.mark.parametrize("channel", range(4))
def test_power_down_frames(channel: int, mode: PowerDownMode, mode_byte: int) -> None:
    frame = bytes((CONTROL_BY_CHANNEL[channel] | 0b1, mode_byte, 0))
    assert dac6574.encode_power_down(channel, mode) == frame
    assert dac6574.decode_frame(frame) == PowerDown(channel, mode)


def test_power_down_code_00_is_also_high_impedance() -> None:
    assert dac6574.decode_frame(bytes((0b0001_0001, 0, 0))) == PowerDown(
        0, PowerDownMode.HIGH_IMPEDANCE
    )


def test_decode_write_rejects_a_power_down_frame() -> None:
    frame = dac6574.encode_power_down(1, PowerDownMode.PULLDOWN_1K)
    with pytest.raises(FrameError, match="power-down"):
        dac6574.decode_write(frame)


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (b"", "3 bytes, got 0"),
        (bytes((0x10, 0x80)), "3 bytes, got 2"),
        (bytes((0x10, 0x80, 0x00, 0x00)), "3 bytes, got 4"),
        (bytes((0b0000_0000, 0, 0)), "L1 L0 = 00"),
        (bytes((0b0010_0000, 0, 0)), "L1 L0 = 10"),
        (bytes((0b0011_0000, 0, 0)), "L1 L0 = 11"),
        (bytes((0b0001_1000, 0, 0)), "bit 3"),
        (bytes((0b0001_0000, 0, 0b0000_0001)), "LS byte bits 5-0"),
        (bytes((0b0001_0001, 0b0100_0001, 0)), "MS byte bits 5-0"),
        (bytes((0b0001_0001, 0b0100_0000, 0b1000_0000)), "power-down LS byte"),
    ],
)
def test_malformed_frames_are_rejected(frame: bytes, message: str) -> None:
    with pytest.raises(FrameError, match=message):
        dac6574.decode_frame(frame)


@given(st.binary(min_size=3, max_size=3))
def test_any_three_bytes_decode_to_a_frame_that_encodes_back_or_raise(data: bytes) -> None:
    try:
        frame = dac6574.decode_frame(data)
    except FrameError:
        return
    if isinstance(frame, Write):
        again = dac6574.encode_write(
            frame.channel, frame.code, extended_address=frame.extended_address
        )
    else:
        again = dac6574.encode_power_down(
            frame.channel, frame.mode, extended_address=frame.extended_address
        )
    assert dac6574.decode_frame(again) == frame


@pytest.mark.parametrize(
    ("volts", "code", "clamped"),
    [
        (-1.0, 0, True),
        (0.0, 0, False),
        (2.5, 512, False),
        (5.0, 1023, False),
        (6.0, 1023, True),
        (math.nan, 0, True),
        (math.inf, 1023, True),
        (-math.inf, 0, True),
        (5.0 * 1023 / 1024, 1023, False),
        (5.0 / 1024 * 0.49, 0, False),
        (5.0 / 1024 * 0.5, 1, False),
    ],
)
def test_code_from_volts_reports_clamps(volts: float, code: int, clamped: bool) -> None:
    conversion = dac6574.code_from_volts(volts)
    assert (conversion.code, conversion.clamped) == (code, clamped)
    if math.isnan(volts):
        assert math.isnan(conversion.requested_volts)
    else:
        assert conversion.requested_volts == volts
    assert conversion.output_volts == pytest.approx(5.0 * code / 1024)


def test_full_scale_is_vref_times_1023_over_1024() -> None:
    assert dac6574.volts_from_code(1023) == pytest.approx(4.9951171875)
    assert dac6574.volts_from_code(512) == 2.5
    assert dac6574.volts_from_code(0) == 0.0
    assert dac6574.volts_from_code(1023, vref_volts=3.3) == pytest.approx(3.3 * 1023 / 1024)


@pytest.mark.parametrize("vref_volts", [5.0, 3.3, 2.5])
def test_every_code_survives_volts_and_back(vref_volts: float) -> None:
    for code in range(1024):
        volts = dac6574.volts_from_code(code, vref_volts)
        assert dac6574.code_from_volts(volts, vref_volts).code == code


@pytest.mark.parametrize("vref_volts", [0.0, -5.0, math.nan, math.inf])
def test_bad_reference_voltage_is_a_config_error(vref_volts: float) -> None:
    with pytest.raises(ConfigError, match="vref_volts"):
        dac6574.code_from_volts(1.0, vref_volts)


def test_addresses() -> None:
    assert list(dac6574.ADDRESSES) == [0x4C, 0x4D, 0x4E, 0x4F]
    assert dac6574.address_for(a1=False, a0=False) == 0x4C
    assert dac6574.address_for(a1=False, a0=True) == 0x4D
    assert dac6574.address_for(a1=True, a0=False) == 0x4E
    assert dac6574.address_for(a1=True, a0=True) == 0x4F
    assert [dac6574.check_address(a) for a in range(0x4C, 0x50)] == [0x4C, 0x4D, 0x4E, 0x4F]


@pytest.mark.parametrize("address", [0x4B, 0x50, 0x48, 0x98, -1])
def test_foreign_address_names_the_allowed_range(address: int) -> None:
    with pytest.raises(ConfigError, match="0x4C-0x4F"):
        dac6574.check_address(address)


@pytest.mark.parametrize(
    ("channel", "code", "message"),
    [
        (4, 0, r"channel.*0\.\.3"),
        (-1, 0, r"channel.*0\.\.3"),
        (0, 1024, r"0\.\.1023"),
        (0, -1, r"0\.\.1023"),
    ],
)
def test_out_of_range_channel_or_code_names_the_range(
    channel: int, code: int, message: str
) -> None:
    with pytest.raises(FrameError, match=message):
        dac6574.encode_write(channel, code)
    with pytest.raises(ValueError, match=message):
        dac6574.encode_write(channel, code)


def test_out_of_range_power_down_channel_and_extended_address() -> None:
    with pytest.raises(FrameError, match=r"0\.\.3"):
        dac6574.encode_power_down(4, PowerDownMode.HIGH_IMPEDANCE)
    with pytest.raises(FrameError, match=r"A3 A2 must be 0\.\.3"):
        dac6574.encode_write(0, 0, extended_address=4)
    with pytest.raises(FrameError, match=r"0\.\.1023"):
        dac6574.volts_from_code(1024)
