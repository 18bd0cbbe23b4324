"""The DAC6574 through the kernel's IIO driver (ti-dac5571): codes into `out_voltageK_raw`.

The port still receives the chip's 3-byte frames; they are decoded with `protocol.dac6574` and
the channel's code is written to `<iio device>/out_voltage<channel>_raw` (power-down frames to
`out_voltage<channel>_powerdown`). The device is found by its IIO name ("dac6574") and, when
several are present, by its I2C parent (`<bus>-00<address>`), never by its number.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from bywire.errors import FrameError, HardwareError
from bywire.hal.linux.device_errors import device_error, reason
from bywire.protocol import dac6574

IIO_NAME = "dac6574"
DRIVER_HINT = "load the ti-dac5571 driver (device tree overlay) or use the raw I2C backend"


def find_iio_dac(sysfs_root: Path, i2c_bus: int, address: int) -> Path | None:
    """The IIO directory of the DAC6574 at `i2c_bus`/`address`, or None if the kernel has none."""
    devices = sysfs_root / "bus" / "iio" / "devices"
    client = f"{i2c_bus}-{address:04x}"
    named = [path for path in sorted(devices.glob("iio:device*")) if _name(path) == IIO_NAME]
    on_client = [path for path in named if path.resolve().parent.name == client]
    return on_client[0] if on_client else None


class IioDac:
    """An `I2cDevice` whose frames go to the IIO driver's sysfs attributes.

    Opening writes 0 to every channel (safe start); `close()` does it again.
    """

    def __init__(self, device: Path) -> None:
        self.device = device
        self.writes = self.failed_writes = 0
        self._powered_down: set[int] = set()
        self._closed = False
        if not (device / "out_voltage0_raw").exists():
            raise HardwareError(f"DAC6574: no IIO DAC at {device}: {DRIVER_HINT}")
        self._zero_all()

    def write(self, data: bytes) -> None:
        if self._closed:
            raise HardwareError(f"DAC6574 at {self.device}: closed")
        try:
            frame = dac6574.decode_frame(data)
        except FrameError as error:
            self.failed_writes += 1
            raise HardwareError(f"DAC6574: frame not sent: {error}") from error
        if isinstance(frame, dac6574.PowerDown):
            self._attribute(f"out_voltage{frame.channel}_powerdown", "1")
            self._powered_down.add(frame.channel)
            return
        if frame.channel in self._powered_down:
            self._attribute(f"out_voltage{frame.channel}_powerdown", "0")
            self._powered_down.discard(frame.channel)
        self._attribute(f"out_voltage{frame.channel}_raw", str(frame.code))
        self.writes += 1

    def close(self) -> None:
        """0 on every channel (best effort); safe to call again."""
        if self._closed:
            return
        # A chip that is gone cannot be zeroed; the enable line already holds the motors off.
        with contextlib.suppress(HardwareError):
            self._zero_all()
        self._closed = True

    def _zero_all(self) -> None:
        for channel in dac6574.CHANNELS:
            self.write(dac6574.encode_write(channel, 0))

    def _attribute(self, name: str, value: str) -> None:
        path = self.device / name
        try:
            path.write_text(value, encoding="ascii")
        except PermissionError as error:
            raise device_error("DAC6574", str(path), error, group="i2c", missing="") from error
        except OSError as error:
            self.failed_writes += 1
            raise HardwareError(f"DAC6574: writing {path} failed ({reason(error)})") from error


def _name(device: Path) -> str:
    try:
        return (device / "name").read_text(encoding="ascii").strip()
    except OSError:
        return ""
