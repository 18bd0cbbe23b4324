"""DAC6574 backends: raw 3-byte writes through an smbus2 stand-in, and the IIO driver's files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from bywire.errors import HardwareError
from bywire.hal.linux.dac_iio import IioDac, find_iio_dac
from bywire.hal.linux.dac_smbus2 import Smbus2Dac
from bywire.protocol import dac6574
from tests.hal.linux.fake_smbus import RecordingSMBus
from tests.hal.linux.fake_sysfs import make_iio_dac, read_iio

ZEROS = [(0x4D, dac6574.encode_write(channel, 0)) for channel in dac6574.CHANNELS]


def _smbus_dac(**adapter: Any) -> tuple[Smbus2Dac, RecordingSMBus]:
    buses: list[RecordingSMBus] = []

    def opener(path: str) -> RecordingSMBus:
        buses.append(RecordingSMBus(path, **adapter))
        return buses[-1]

    return Smbus2Dac("/dev/i2c-1", 0x4D, open_bus=opener), buses[0]


def test_smbus2_sends_each_frame_as_one_raw_transfer() -> None:
    dac, bus = _smbus_dac()
    frame = dac6574.encode_write(1, 613)
    dac.write(frame)
    assert bus.path == "/dev/i2c-1"
    assert bus.transfers == [*ZEROS, (0x4D, frame)]  # opened at 0 V on every channel
    assert frame == bytes((0b0001_0010, 613 >> 2, (613 & 0b11) << 6))


def test_smbus2_on_an_smbus_only_adapter_sends_the_same_bytes_as_i2c_block_writes() -> None:
    # i2c-stub and Intel i801 refuse plain I2C (EOPNOTSUPP); this was "no acknowledge... check
    # the wiring" before. tests/kernel reads the bytes back from the kernel's i2c-stub.
    dac, bus = _smbus_dac(smbus_only=True)
    assert dac.smbus_only
    frame = dac6574.encode_write(1, 613)
    dac.write(frame)
    assert bus.transfers == [*ZEROS, (0x4D, frame)]


def test_smbus2_a_plain_i2c_refusal_is_named_not_taken_for_a_missing_acknowledge() -> None:
    dac, bus = _smbus_dac()
    bus.smbus_only = True  # the adapter claimed plain I2C, then refused it
    with pytest.raises(HardwareError, match="this adapter cannot do plain I2C") as refused:
        dac.write(dac6574.encode_write(0, 1))
    assert "acknowledge" not in str(refused.value)


def test_smbus2_an_address_a_kernel_driver_owns_is_refused_with_the_way_out() -> None:
    with pytest.raises(HardwareError, match="a kernel driver owns this address") as refused:
        _smbus_dac(owner="ti-dac5571")
    assert "1-004d/driver/unbind" in str(refused.value)
    assert "IIO" in str(refused.value)


def test_smbus2_no_acknowledge_is_a_hardware_error_and_counted() -> None:
    dac, bus = _smbus_dac()
    bus.nak = True
    with pytest.raises(HardwareError, match=r"0x4D on /dev/i2c-1: no acknowledge \(Remote I/O"):
        dac.write(dac6574.encode_write(0, 1))
    assert dac.failed_writes == 1


def test_smbus2_close_zeroes_every_channel_once() -> None:
    dac, bus = _smbus_dac()
    dac.write(dac6574.encode_write(2, 1000))
    dac.close()
    dac.close()
    assert bus.transfers[-4:] == ZEROS
    assert bus.closed == 1
    with pytest.raises(HardwareError, match="closed"):
        dac.write(dac6574.encode_write(2, 1))


def test_smbus2_a_chip_that_does_not_answer_fails_at_open() -> None:
    def silent(path: str) -> RecordingSMBus:
        bus = RecordingSMBus(path)
        bus.nak = True
        return bus

    with pytest.raises(HardwareError, match="check the wiring, power and pins A1 A0"):
        Smbus2Dac("/dev/i2c-1", 0x4C, open_bus=silent)


def test_smbus2_a_missing_bus_says_how_to_enable_it(tmp_path: Path) -> None:
    with pytest.raises(HardwareError, match="i2c-7 does not exist: enable I2C"):
        Smbus2Dac(str(tmp_path / "i2c-7"), 0x4C)


def test_iio_device_found_by_name_and_i2c_parent_not_number(tmp_path: Path) -> None:
    make_iio_dac(tmp_path, 0, 0, 0x4C)  # the same chip type on another bus
    wanted = make_iio_dac(tmp_path, 3, 1, 0x4C)
    assert find_iio_dac(tmp_path, 1, 0x4C) == wanted
    assert find_iio_dac(tmp_path, 1, 0x4D) is None
    assert find_iio_dac(tmp_path / "absent", 1, 0x4C) is None


def test_iio_writes_the_decoded_code_and_handles_power_down(tmp_path: Path) -> None:
    device = make_iio_dac(tmp_path, 0, 1, 0x4C)
    dac = IioDac(device)
    dac.write(dac6574.encode_write(3, 777))
    assert read_iio(device, 3) == 777
    dac.write(dac6574.encode_power_down(3, dac6574.PowerDownMode.PULLDOWN_1K))
    assert (device / "out_voltage3_powerdown").read_text() == "1"
    dac.write(dac6574.encode_write(3, 5))
    assert ((device / "out_voltage3_powerdown").read_text(), read_iio(device, 3)) == ("0", 5)
    dac.close()
    dac.close()
    assert [read_iio(device, channel) for channel in dac6574.CHANNELS] == [0, 0, 0, 0]


def test_iio_a_failed_write_is_a_hardware_error(tmp_path: Path) -> None:
    device = make_iio_dac(tmp_path, 0, 1, 0x4C)
    dac = IioDac(device)
    (device / "out_voltage1_raw").unlink()
    (device / "out_voltage1_raw").mkdir()  # the write fails as a NAK makes the driver's fail
    with pytest.raises(HardwareError, match="out_voltage1_raw failed"):
        dac.write(dac6574.encode_write(1, 10))
    assert dac.failed_writes == 1
