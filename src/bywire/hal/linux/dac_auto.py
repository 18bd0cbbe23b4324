"""The DAC6574 on the robot's I2C bus: the kernel's IIO driver when it owns the chip, else raw
writes through /dev/i2c-N (`[drive.dac] backend = "auto"`)."""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING

from bywire.hal.linux.dac_iio import IioDac, find_iio_dac
from bywire.hal.linux.dac_smbus2 import Smbus2Dac

if TYPE_CHECKING:
    from bywire.config import DacOutput
    from bywire.hal.opening import LinuxPaths
    from bywire.hal.ports import I2cDevice


def open_dac(dac: DacOutput, paths: LinuxPaths, stack: contextlib.ExitStack) -> I2cDevice:
    device = find_iio_dac(paths.sysfs_root, dac.i2c_bus, dac.address)
    if device is None:
        raw = Smbus2Dac(paths.device(f"i2c-{dac.i2c_bus}"), dac.address)
        stack.callback(raw.close)
        return raw
    iio = IioDac(device)
    stack.callback(iio.close)
    return iio
