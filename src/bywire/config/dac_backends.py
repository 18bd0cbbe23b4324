"""Every DAC backend, one row each: its `[drive.dac] backend` name, where its opener lives, and
what the machine needs for it.

The rows are the one list: the configuration allows exactly their names, `hal.opening` imports
the chosen row's opener (and no other backend's module), and the HAL conformance suite runs a rig
for every row (`tests/hal/rigs.py:DAC_RIGS`, checked against these rows). Openers are named by
module path, as python-can's interface registry names its buses, so the configuration below the
hardware seam names them without importing them.

An opener is `open_dac(dac: DacOutput, paths: LinuxPaths, stack: ExitStack) -> I2cDevice`: it
opens the device, registers its close on `stack`, and raises `HardwareError` naming the problem.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class DacBackend:
    name: str  # the value of `[drive.dac] backend`
    module: str  # the module whose `open_dac` opens it, imported only when chosen
    needs: str  # what the machine must offer, said when it does not


DAC_BACKENDS: tuple[DacBackend, ...] = (
    DacBackend(
        "auto",
        "bywire.hal.linux.dac_auto",
        "the kernel's ti-dac5571 IIO driver bound to the chip, else /dev/i2c-N (i2c-dev)",
    ),
)
DAC_BACKEND_NAMES = tuple(row.name for row in DAC_BACKENDS)


def dac_backend(name: str) -> DacBackend:
    """The row of that name (the configuration has allowed only these)."""
    return next(row for row in DAC_BACKENDS if row.name == name)
