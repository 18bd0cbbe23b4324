"""CRC-8/SAE-J1850: the catalogue check value, AUTOSAR's published vectors, a bitwise reference."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.protocol.crc8 import crc8

# AUTOSAR "Specification of CRC Routines", 8-bit SAE J1850 check values (also in the unit tests
# of several public Crc_CalculateCRC8 implementations).
AUTOSAR_VECTORS = [
    (bytes([0x00, 0x00, 0x00, 0x00]), 0x59),
    (bytes([0xF2, 0x01, 0x83]), 0x37),
    (bytes([0x0F, 0xAA, 0x00, 0x55]), 0x79),
    (bytes([0x00, 0xFF, 0x55, 0x11]), 0xB8),
    (bytes([0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF]), 0xCB),
    (bytes([0x92, 0x6B, 0x55]), 0x8C),
    (bytes([0xFF, 0xFF, 0xFF, 0xFF]), 0x74),
]


def _bitwise_reference(data: bytes) -> int:
    """The textbook MSB-first shift register, independent of the table."""
    register = 0xFF
    for byte in data:
        register ^= byte
        for _bit in range(8):
            carry = register & 0x80
            register = (register << 1) & 0xFF
            if carry:
                register ^= 0x1D
    return register ^ 0xFF


def test_check_value_of_123456789_is_0x4b() -> None:
    assert crc8(b"123456789") == 0x4B


@pytest.mark.parametrize(("data", "expected"), AUTOSAR_VECTORS)
def test_autosar_published_vectors(data: bytes, expected: int) -> None:
    assert crc8(data) == expected


def test_accepts_any_iterable_of_bytes() -> None:
    assert crc8(iter([0xF2, 0x01, 0x83])) == crc8(bytearray(b"\xf2\x01\x83")) == 0x37


@given(st.binary(max_size=16))
def test_table_matches_bitwise_reference(data: bytes) -> None:
    assert crc8(data) == _bitwise_reference(data)


@given(st.binary(min_size=1, max_size=8), st.data())
def test_every_single_bit_error_changes_the_crc(data: bytes, draw: st.DataObject) -> None:
    bit = draw.draw(st.integers(0, 8 * len(data) - 1))
    corrupted = bytearray(data)
    corrupted[bit // 8] ^= 1 << (bit % 8)
    assert crc8(corrupted) != crc8(data)
