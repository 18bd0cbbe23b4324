"""Opening a python-can bus from the configuration, with errors that say what to do.

python-can reports a missing driver or adapter in many ways (CanInterfaceNotImplementedError,
CanInitializationError, OSError, even NameError when Kvaser's canlib is absent); each becomes one
HardwareError naming the interface, the channel and the fix. SocketCAN's state is read from sysfs
first, because python-can cannot set its bitrate (that needs `ip link`, as root).
"""

from __future__ import annotations

import errno
import logging
import socket
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
        check_socketcan(settings.channel, settings.bitrate_bps, settings.sysfs_root)
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
        raise open_error(str(settings), settings.interface, error) from error


NO_SOCKETCAN = (
    "this kernel has no SocketCAN (address family AF_CAN not supported): load it with"
    " `sudo modprobe can-raw` (and your adapter's driver, or `modprobe vcan` for a virtual bus);"
    " in a container or WSL the host's kernel must provide it"
)


def check_socketcan(channel: str, bitrate_bps: int, sysfs_root: Path = Path("/sys")) -> None:
    """HardwareError with the fix when SocketCAN or the interface is missing, or it is down."""
    net = sysfs_root / "class" / "net"
    if not net.is_dir():
        _check_af_can(f"CAN socketcan {channel}")
        return  # no sysfs here (a container): let python-can try
    device = net / channel
    up = (
        f"sudo ip link set {channel} up type can bitrate {bitrate_bps}"
        " restart-ms 100 (or deploy/80-can.network)"
    )
    if not device.exists():
        _check_af_can(f"CAN socketcan {channel}")  # no SocketCAN at all: that fix comes first
        raise HardwareError(
            f"CAN socketcan {channel}: no such network interface: plug in the adapter"
            f" and load its driver (`ip link` lists interfaces), then {up}"
        )
    state = _read(device / "operstate")
    if state == "down":
        raise HardwareError(f"CAN socketcan {channel} is down: {up}")


def _check_af_can(where: str) -> None:
    """A kernel without CAN refuses the socket itself, before any interface is looked at."""
    family = getattr(socket, "AF_CAN", None)
    if family is None:
        raise HardwareError(f"{where}: SocketCAN needs Linux; use another python-can interface")
    try:
        socket.socket(family, socket.SOCK_RAW, socket.CAN_RAW).close()
    except OSError as error:
        if error.errno == errno.EAFNOSUPPORT:
            raise HardwareError(f"{where}: {NO_SOCKETCAN}") from error


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="ascii").strip()
    except OSError:
        return ""


def open_error(what: str, interface: str, error: Exception) -> HardwareError:
    """One line for python-can's failure to open `interface`, with the fix (`what`: the bus as
    the user named it)."""
    where = f"CAN {what}"
    hint = INSTALL_HINTS.get(interface, "check the adapter, its driver and the channel")
    if isinstance(error, OSError) and error.errno == errno.EAFNOSUPPORT:
        return HardwareError(f"{where}: {NO_SOCKETCAN}")
    if isinstance(error, NotImplementedError | NameError | ImportError):
        return HardwareError(f"{where}: interface not available here: {hint}")
    if isinstance(error, PermissionError):
        return HardwareError(
            f"{where}: permission denied: add the user to the adapter's group"
            " (plugdev/dialout) or install deploy/99-bywire.rules"
        )
    return HardwareError(f"{where}: cannot open: {reason(error)}: {hint}")
