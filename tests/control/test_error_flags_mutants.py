"""Error flag names cover exactly the 64 bits of the CAN report."""

from __future__ import annotations

from bywire.control.error_flags import flag_names


def test_bits_beyond_the_64_bit_report_are_not_named() -> None:
    assert flag_names(1 << 63) == ["BIT63"]
    assert flag_names(1 << 64) == []
