"""Error flags: stable bit positions (they are on the wire) and readable names."""

from __future__ import annotations

from bywire.error_flags import RECOVERABLE, ErrorFlag, flag_names


def test_figure_23_flags_keep_their_bit_positions() -> None:
    assert ErrorFlag.TASK_CRASHED == 1 << 0
    assert ErrorFlag.DAC_WRITE_FAILED == 1 << 6
    assert ErrorFlag.RC_TIMEOUT == 1 << 8
    assert ErrorFlag.IBUS_CHECKSUM == 1 << 10


def test_every_flag_is_one_distinct_bit_within_64() -> None:
    values = [flag.value for flag in ErrorFlag]
    assert len(set(values)) == len(values)
    assert all(value.bit_count() == 1 and value < 1 << 64 for value in values)


def test_names_of_set_bits_and_unknown_bits() -> None:
    flags = ErrorFlag.RC_TIMEOUT | ErrorFlag.CAN_BUS_OFF | (1 << 63)
    assert flag_names(flags) == ["CAN_BUS_OFF", "RC_TIMEOUT", "BIT63"]
    assert flag_names(0) == []


def test_latching_faults_are_not_recoverable() -> None:
    assert ErrorFlag.WATCHDOG_TRIPPED not in RECOVERABLE
    assert ErrorFlag.DAC_FAULT_STOP not in RECOVERABLE
    assert ErrorFlag.RC_TIMEOUT in RECOVERABLE


# Tests added after mutation testing (docs/mutation.md). Error flag names cover exactly the 64
# bits of the CAN report.


def test_bits_beyond_the_64_bit_report_are_not_named() -> None:
    assert flag_names(1 << 63) == ["BIT63"]
    assert flag_names(1 << 64) == []
