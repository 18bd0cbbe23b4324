"""Opening a python-can bus from the configuration, with errors that say what to do.

python-can reports a missing driver or adapter in many ways (CanInterfaceNotImplementedError,
CanInitializationError, OSError, even NameError when Kvaser's canlib is absent); each becomes one
HardwareError naming the interface, the channel and the fix. SocketCAN's state is read from sysfs
first, because python-can cannot set its bitrate (that needs `ip link`, as root).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

from bywire.errors import ConfigError, HardwareError
from bywire.hal.linux.device_errors import reason
from bywire.protocol import bittiming

STANDARD_ID_MASK = 0x7FF
INSTALL_HINTS = {
    "kvaser": "install Kvaser's linuxcan driver and CANlib",
    "pcan": "install PEAK's PCAN-Basic library (libpcanbasic), or use socketcan with peak_usb",
    "gs_usb": 'pip install pyusb, or use interface = "socketcan" with the gs_usb kernel driver',
    "socketcan": "load SocketCAN (sudo modprobe can-raw) on a Linux kernel with CAN support",
}


@dataclass(frozen=True, slots=True)
class BusSettings:
    """What python-can needs: interface, channel, bitrate, and the ids to let through."""

    interface: str
    channel: str
    bitrate_bps: int = 500_000
    accept_ids: tuple[int, ...] = ()
    sample_point: float = 0.875
    clock_hz: int | None = None
    sysfs_root: Path = Path("/sys")

    def __str__(self) -> str:
        return f"{self.interface} {self.channel}"


def check_bit_timing(settings: BusSettings) -> None:
    """ConfigError when `clock_hz` is set and no exact bxCAN setting gives the bitrate."""
    if settings.clock_hz is None:
        return
    rows = bittiming.solutions(settings.clock_hz, settings.bitrate_bps, settings.sample_point)
    if not rows:
        raise ConfigError(
            f"can.bitrate_bps = {settings.bitrate_bps}: no exact bit timing on a"
            f" {settings.clock_hz} Hz clock at sample point {settings.sample_point}"
            " (see `bywire bittiming`)"
        )


def open_bus(settings: BusSettings) -> can.BusABC:
    """The bus, filtered to `accept_ids`; HardwareError with the fix when it cannot be opened."""
    check_bit_timing(settings)
    if settings.interface not in can.VALID_INTERFACES:
        known = ", ".join(sorted(can.VALID_INTERFACES))
        raise HardwareError(
            f"CAN {settings}: unknown python-can interface {settings.interface!r}:"
            f" fix can.interface (known: {known})"
        )
    if settings.interface == "socketcan":
        _check_socketcan(settings)
    filters: list[Any] = [
        {"can_id": frame_id, "can_mask": STANDARD_ID_MASK, "extended": False}
        for frame_id in settings.accept_ids
    ]
    # python-can's drivers log their import troubles; our one-line error says it better.
    logging.getLogger("can").setLevel(logging.ERROR)
    try:
        return can.Bus(
            interface=settings.interface,
            channel=settings.channel,
            bitrate=settings.bitrate_bps,
            can_filters=filters or None,
        )
    except Exception as error:  # drivers raise anything, even NameError
        raise _open_error(settings, error) from error


def _check_socketcan(settings: BusSettings) -> None:
    net = settings.sysfs_root / "class" / "net"
    if not net.is_dir():
        return  # no sysfs here (a container): let python-can try
    device = net / settings.channel
    up = (
        f"sudo ip link set {settings.channel} up type can bitrate {settings.bitrate_bps}"
        " restart-ms 100 (or deploy/80-can.network)"
    )
    if not device.exists():
        raise HardwareError(
            f"CAN socketcan {settings.channel}: no such network interface: plug in the adapter"
            f" and load its driver (`ip link` lists interfaces), then {up}"
        )
    state = _read(device / "operstate")
    if state == "down":
        raise HardwareError(f"CAN socketcan {settings.channel} is down: {up}")


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="ascii").strip()
    except OSError:
        return ""


def _open_error(settings: BusSettings, error: Exception) -> HardwareError:
    where = f"CAN {settings}"
    hint = INSTALL_HINTS.get(settings.interface, "check the adapter, its driver and can.channel")
    if isinstance(error, NotImplementedError | NameError | ImportError):
        return HardwareError(f"{where}: interface not available here: {hint}")
    if isinstance(error, PermissionError):
        return HardwareError(
            f"{where}: permission denied: add the user to the adapter's group"
            " (plugdev/dialout) or install deploy/99-bywire.rules"
        )
    return HardwareError(f"{where}: cannot open: {reason(error)}: {hint}")
