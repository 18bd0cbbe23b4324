"""CRC-8/SAE-J1850 (the AUTOSAR CRC-8) that protects every command frame of the CAN protocol.

Parameters, in the Rocksoft/"reveng" model:

    width 8, poly 0x1D (x^8 + x^4 + x^3 + x^2 + 1), init 0xFF, refin false, refout false,
    xorout 0xFF, check 0x4B (the CRC of the ASCII bytes "123456789")

This is ``Crc_CalculateCRC8`` of the AUTOSAR CRC library, and what the firmware side implements
in C with the same 256-entry table. The function is pure and table-driven: one lookup per byte.
"""

from __future__ import annotations

from collections.abc import Iterable

POLYNOMIAL = 0x1D
INITIAL_VALUE = 0xFF
FINAL_XOR = 0xFF


def _table_entry(byte: int) -> int:
    """The register after shifting one byte through the polynomial, MSB first."""
    register = byte
    for _bit in range(8):
        register = ((register << 1) ^ POLYNOMIAL) if register & 0x80 else register << 1
        register &= 0xFF
    return register


_TABLE: tuple[int, ...] = tuple(_table_entry(byte) for byte in range(256))


def crc8(data: Iterable[int]) -> int:
    """The CRC-8/SAE-J1850 of ``data`` (bytes, bytearray or any iterable of 0…255)."""
    register = INITIAL_VALUE
    for byte in data:
        register = _TABLE[register ^ byte]
    return register ^ FINAL_XOR
