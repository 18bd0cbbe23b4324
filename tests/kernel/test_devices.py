"""Each Linux backend against the kernel's own drivers: PWM core, i2c-dev with i2c-stub and a
plain-I2C adapter, the kernel's ti-dac5571 (IIO), gpio-sim."""

from __future__ import annotations

import errno
from collections.abc import Iterator
from pathlib import Path

import pytest
from smbus2 import SMBus, i2c_msg

from bywire.errors import HardwareError
from bywire.hal.linux.dac_iio import IioDac, find_iio_dac
from bywire.hal.linux.dac_smbus2 import Smbus2Dac
from bywire.hal.linux.gpio_gpiod import GpiodOutputs, LineSpec
from bywire.hal.linux.pwm_sysfs import SysfsPwm, find_pwm_chip
from bywire.protocol import dac6574
from tests.kernel.guest import DAC_ADDRESS, GpioSim, I2cSim, I2cStub, pwm_applied, pwm_sim

FRAME_613 = bytes((0b0001_0010, 0x99, 0x40))  # channel B, code 613 (datasheet: ctrl, MSB, LSB)


@pytest.fixture
def stub() -> Iterator[I2cStub]:
    made = I2cStub()
    yield made
    made.close()


@pytest.fixture
def sim() -> Iterator[I2cSim]:
    made = I2cSim()
    yield made
    made.close()


def test_the_pwm_core_refuses_a_duty_cycle_on_a_fresh_channel() -> None:
    chip = pwm_sim()
    (chip / "export").write_text("0")
    with pytest.raises(OSError, match="Invalid argument") as refused:
        (chip / "pwm0" / "duty_cycle").write_text("0")  # what SysfsPwm wrote first
    assert refused.value.errno == errno.EINVAL


def test_the_pwm_opens_on_a_fresh_channel_and_drives_the_chip() -> None:
    chip = pwm_sim()
    assert find_pwm_chip(Path("/sys"), "bywire-pwm-sim.0") == chip
    pwm = SysfsPwm(chip, 1, 0.020, "steering.pwm")
    assert pwm_applied(1) == (20_000_000, 0, True)
    pwm.set_pulse(0.0015)
    assert pwm_applied(1) == (20_000_000, 1_500_000, True)
    pwm.close()
    assert pwm_applied(1) == (20_000_000, 0, False)
    shorter = SysfsPwm(chip, 1, 0.001)  # a period shorter than the one left: duty 0 first
    assert pwm_applied(1) == (1_000_000, 0, True)
    shorter.close()


def test_i2c_stub_refuses_plain_i2c(stub: I2cStub) -> None:
    with SMBus(stub.bus) as bus, pytest.raises(OSError, match="not supported") as refused:
        bus.i2c_rdwr(i2c_msg.write(DAC_ADDRESS, FRAME_613))
    assert refused.value.errno == errno.EOPNOTSUPP


def test_an_smbus_only_adapter_gets_the_datasheet_bytes_as_i2c_block_writes(
    stub: I2cStub,
) -> None:
    dac = Smbus2Dac(f"/dev/i2c-{stub.bus}", DAC_ADDRESS)
    assert dac.smbus_only
    assert dac6574.encode_write(1, 613) == FRAME_613
    dac.write(FRAME_613)
    with SMBus(stub.bus) as bus:  # the stub kept MSB and LSB from the control byte on
        assert [bus.read_byte_data(DAC_ADDRESS, 0x12 + index) for index in (0, 1)] == [0x99, 0x40]
    assert stub.code(1) == 613
    dac.close()
    assert [stub.code(channel) for channel in dac6574.CHANNELS] == [0, 0, 0, 0]


def test_a_plain_i2c_adapter_gets_each_frame_as_one_transfer(sim: I2cSim) -> None:
    dac = Smbus2Dac(f"/dev/i2c-{sim.bus}", DAC_ADDRESS)
    assert not dac.smbus_only
    dac.write(FRAME_613)
    assert sim.written()[-1] == FRAME_613
    assert sim.written()[:4] == [dac6574.encode_write(channel, 0) for channel in range(4)]
    dac.close()


def test_a_device_that_stops_answering_is_a_missing_acknowledge(sim: I2cSim) -> None:
    dac = Smbus2Dac(f"/dev/i2c-{sim.bus}", DAC_ADDRESS)
    sim.set_present(False)
    with pytest.raises(HardwareError, match=r"no acknowledge \(No such device or address\)"):
        dac.write(FRAME_613)
    assert dac.failed_writes == 1
    sim.set_present(True)
    dac.write(FRAME_613)
    dac.close()


def test_the_iio_backend_drives_the_kernels_ti_dac5571(sim: I2cSim) -> None:
    iio = sim.bind_driver()
    device = Path("/sys/bus/iio/devices") / iio.name
    assert find_iio_dac(Path("/sys"), sim.bus, DAC_ADDRESS) == device
    dac = IioDac(device)
    dac.write(FRAME_613)
    assert (iio / "out_voltage1_raw").read_text().strip() == "613"
    assert sim.written()[-1] == FRAME_613  # the kernel driver put the datasheet's bytes on the bus
    dac.close()
    assert sim.code(1) == 0


def test_an_address_a_kernel_driver_owns_is_refused_with_the_way_out(sim: I2cSim) -> None:
    sim.bind_driver()
    before = len(sim.written())
    with pytest.raises(HardwareError, match="a kernel driver owns this address") as refused:
        Smbus2Dac(f"/dev/i2c-{sim.bus}", DAC_ADDRESS)
    assert f"{sim.bus}-004c/driver/unbind" in str(refused.value)
    assert len(sim.written()) == before  # nothing written behind the driver's back


def test_gpio_lines_are_requested_low_and_read_back_from_gpio_sim() -> None:
    chip = GpioSim("bywire-kernel-gpio", ["ID_SD", "MOTORS_ENABLE", "EBRAKE_RELEASE"])
    try:
        specs = {
            "motors_enable": LineSpec("drive.motors_enable", "bywire-kernel-gpio", "MOTORS_ENABLE"),
            "ebrake_release": LineSpec("ebrake.release", "bywire-kernel-gpio", "EBRAKE_RELEASE"),
        }
        outputs = GpiodOutputs(specs)
        assert (chip.level("MOTORS_ENABLE"), chip.level("EBRAKE_RELEASE")) == (False, False)
        outputs.lines["ebrake_release"].set(True)
        assert (chip.level("MOTORS_ENABLE"), chip.level("EBRAKE_RELEASE")) == (False, True)
        outputs.close()
        assert chip.level("EBRAKE_RELEASE") is False
    finally:
        chip.close()


def test_a_gpio_chip_that_goes_away_fails_the_write_with_the_kernels_reason() -> None:
    chip = GpioSim("bywire-kernel-gpio", ["MOTORS_ENABLE"])
    spec = LineSpec("drive.motors_enable", "bywire-kernel-gpio", "MOTORS_ENABLE")
    outputs = GpiodOutputs({"motors_enable": spec})
    chip.close()
    gone = r"GPIO drive.motors_enable: cannot set \(No such device"
    with pytest.raises(HardwareError, match=gone):
        outputs.lines["motors_enable"].set(True)
    outputs.close()  # and closing what is gone is no error
