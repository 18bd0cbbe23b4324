"""TI DAC6574 (4-channel, 10-bit, I2C) frames: encode and decode one channel's write, no I/O.

The I2C driver sends the address byte (7-bit address 1 0 0 1 1 A1 A0, then R/W = 0); this
module builds the three bytes that follow it (thesis Figures 11 and 12, datasheet SLAS408
Tables 2, 4 and 8). Single-channel "write and update" (L1 L0 = 01) is the only load mode used:

    control byte                       MS byte                   LS byte
    +--+--+--+--+-+----+----+---+      +--+--+--+--+--+--+--+--+  +--+--+-+-+-+-+-+-+
    |A3|A2|L1|L0|X|Sel1|Sel0|PD0|      |D9|D8|D7|D6|D5|D4|D3|D2|  |D1|D0|0|0|0|0|0|0|
    +--+--+--+--+-+----+----+---+      +--+--+--+--+--+--+--+--+  +--+--+-+-+-+-+-+-+
     0  0  0  1  0  channel 0-3  0      10-bit code, left-aligned in 16 bits

    power down (PD0 = 1): the MS byte's two top bits choose the output state
    +--+--+--+--+-+----+----+---+      +---+---+--+--+--+--+--+--+  +--------+
    |A3|A2| 0| 1|0|Sel1|Sel0| 1 |      |PD1|PD0| 0| 0| 0| 0| 0| 0|  |00000000|
    +--+--+--+--+-+----+----+---+      +---+---+--+--+--+--+--+--+  +--------+
    PD1 PD0: 01 = 1 kOhm to GND, 10 = 100 kOhm to GND, 11 (and 00) = high impedance

A3 A2 are the extended address bits of the sibling DAC6573; the DAC6574 has no such pins and
its datasheet shows them as 0, so they default to 0. X and the LS byte's low bits are "don't
care" to the chip; the encoder writes 0 there and the decoder rejects anything else, so a
simulated DAC flags a corrupted frame instead of guessing. Vout = Vref * code / 1024.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from bywire.errors import ConfigError, FrameError

ADDRESSES = range(0x4C, 0x50)
CHANNELS = range(4)
CODES = range(1024)
EXTENDED_ADDRESSES = range(4)
FRAME_LENGTH = 3
DEFAULT_VREF_VOLTS = 5.0

_LOAD_WRITE_AND_UPDATE = 0b01
_LOAD_SHIFT = 4
_CHANNEL_SHIFT = 1
_EXTENDED_ADDRESS_SHIFT = 6
_POWER_DOWN_FLAG = 0b1
_DONT_CARE_CONTROL = 0b0000_1000
_MODE_SHIFT = 6
_CODE_STEPS = 1024


class PowerDownMode(enum.IntEnum):
    """Output state of a powered-down channel; the value is the PD1 PD0 bit pair."""

    PULLDOWN_1K = 0b01
    PULLDOWN_100K = 0b10
    HIGH_IMPEDANCE = 0b11


@dataclass(frozen=True)
class Write:
    """Set one channel's 10-bit code and update its output at once."""

    channel: int
    code: int
    extended_address: int = 0

    # written out, as the dataclass would make it: compiled, stores into the struct
    def __init__(self, channel: int, code: int, extended_address: int = 0) -> None:
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "code", code)
        object.__setattr__(self, "extended_address", extended_address)


@dataclass(frozen=True)
class PowerDown:
    """Power one channel down; its DAC register keeps the last code."""

    channel: int
    mode: PowerDownMode
    extended_address: int = 0


Frame = Write | PowerDown


@dataclass(frozen=True)
class Conversion:
    """A voltage turned into a code; `clamped` says the request lay outside 0 V ... Vref."""

    code: int
    clamped: bool
    requested_volts: float
    output_volts: float

    # written out, as the dataclass would make it: compiled, stores into the struct
    def __init__(
        self, code: int, clamped: bool, requested_volts: float, output_volts: float
    ) -> None:
        object.__setattr__(self, "code", code)
        object.__setattr__(self, "clamped", clamped)
        object.__setattr__(self, "requested_volts", requested_volts)
        object.__setattr__(self, "output_volts", output_volts)


def address_for(a1: bool, a0: bool) -> int:
    """The 7-bit I2C address for the levels on pins A1 and A0 (0x4C ... 0x4F)."""
    return ADDRESSES.start | int(a1) << 1 | int(a0)


def check_address(address: int) -> int:
    """Return `address` if a DAC6574 can answer to it, else raise ConfigError."""
    if address not in ADDRESSES:
        raise ConfigError(
            f"DAC6574 I2C address {address:#04x} is outside 0x4C-0x4F (0b10011 A1 A0)"
        )
    return address


def encode_write(channel: int, code: int, *, extended_address: int = 0) -> bytes:
    """The 3 bytes that set `channel` (0 = A ... 3 = D) to `code` (0 ... 1023) and update it."""
    control = _control_byte(channel, extended_address, power_down=False)
    _check(code, CODES, "code")
    return bytes((control, code >> 2, (code & 0b11) << 6))


def encode_power_down(channel: int, mode: PowerDownMode, *, extended_address: int = 0) -> bytes:
    """The 3 bytes that power `channel` down into `mode`."""
    control = _control_byte(channel, extended_address, power_down=True)
    return bytes((control, PowerDownMode(mode) << _MODE_SHIFT, 0))


def decode_frame(data: bytes | bytearray) -> Frame:
    """Parse a 3-byte frame into a Write or a PowerDown; FrameError if it is not one."""
    if len(data) != FRAME_LENGTH:
        raise FrameError(f"DAC6574 frame must be {FRAME_LENGTH} bytes, got {len(data)}")
    control, high, low = data
    _check_control(control)
    channel = control >> _CHANNEL_SHIFT & 0b11
    extended_address = control >> _EXTENDED_ADDRESS_SHIFT
    if control & _POWER_DOWN_FLAG:
        return PowerDown(channel, _decode_mode(high, low), extended_address)
    _check_zero(low & 0b0011_1111, "LS byte bits 5-0")
    return Write(channel, high << 2 | low >> 6, extended_address)


def decode_write(data: bytes | bytearray, *, extended_address: int = 0) -> tuple[int, int]:
    """Parse a write frame into (channel, code); FrameError for any other frame."""
    frame = decode_frame(data)
    if isinstance(frame, PowerDown):
        raise FrameError(f"power-down frame for channel {frame.channel}, not a write")
    if frame.extended_address != extended_address:
        raise FrameError(
            f"extended address bits A3 A2 = {frame.extended_address:02b}, "
            f"expected {extended_address:02b}"
        )
    return frame.channel, frame.code


def code_from_volts(volts: float, vref_volts: float = DEFAULT_VREF_VOLTS) -> Conversion:
    """The nearest code for `volts`; a request outside 0 V ... Vref (or NaN) is clamped.

    Vref itself is in range: it maps to the top code 1023 (Vref * 1023/1024), one LSB short,
    which is quantisation rather than a clamp.
    """
    _check_vref(vref_volts)
    clamped = not 0.0 <= volts <= vref_volts
    code = _nearest_code(volts, vref_volts)
    return Conversion(code, clamped, volts, volts_from_code(code, vref_volts))


def volts_from_code(code: int, vref_volts: float = DEFAULT_VREF_VOLTS) -> float:
    """The ideal output voltage for `code`: Vref * code / 1024."""
    _check(code, CODES, "code")
    _check_vref(vref_volts)
    return vref_volts * code / _CODE_STEPS


def _nearest_code(volts: float, vref_volts: float) -> int:
    if math.isnan(volts) or volts <= 0.0:
        return 0
    if volts >= vref_volts:
        return CODES[-1]
    return min(math.floor(volts / vref_volts * _CODE_STEPS + 0.5), CODES[-1])


def _control_byte(channel: int, extended_address: int, *, power_down: bool) -> int:
    _check(channel, CHANNELS, "channel (A-D)")
    _check(extended_address, EXTENDED_ADDRESSES, "extended address A3 A2")
    return (
        extended_address << _EXTENDED_ADDRESS_SHIFT
        | _LOAD_WRITE_AND_UPDATE << _LOAD_SHIFT
        | channel << _CHANNEL_SHIFT
        | int(power_down)
    )


def _check_control(control: int) -> None:
    load = control >> _LOAD_SHIFT & 0b11
    if load != _LOAD_WRITE_AND_UPDATE:
        raise FrameError(f"load bits L1 L0 = {load:02b}; only 01 (write and update) is used")
    _check_zero(control & _DONT_CARE_CONTROL, "control byte bit 3 (X)")


def _decode_mode(high: int, low: int) -> PowerDownMode:
    _check_zero(high & 0b0011_1111, "power-down MS byte bits 5-0")
    _check_zero(low, "power-down LS byte")
    # 00 is the datasheet's second high-impedance code; the encoder always writes 11.
    return PowerDownMode(high >> _MODE_SHIFT or PowerDownMode.HIGH_IMPEDANCE)


def _check(value: int, allowed: range, name: str) -> None:
    if value not in allowed:
        raise FrameError(f"{name} must be {allowed.start}..{allowed.stop - 1}, got {value}")


def _check_zero(bits: int, where: str) -> None:
    if bits:
        raise FrameError(f"{where} must be 0, got {bits:#04x}")


def _check_vref(vref_volts: float) -> None:
    if not 0.0 < vref_volts < math.inf:
        raise ConfigError(f"vref_volts must be a finite voltage > 0 V, got {vref_volts}")
