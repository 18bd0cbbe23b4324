"""The gamepad's device, the thin shell around ``bywire.teleop.gamepad``: open, poll, describe.

evdev is Linux-only and an optional extra (``pip install 'bywire[gamepad]'``), imported here
only when ``--gamepad`` is given. Every failure to open is a ``HardwareError`` whose one line
names the fix (the ``input`` group, the path, the package); the CLI prints it and exits 2.
"""

from __future__ import annotations

import errno
import importlib
import os
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from bywire.errors import HardwareError
from bywire.teleop.gamepad import AxisRange, PadState, disconnected, step
from bywire.teleop.state import TeleopState

if TYPE_CHECKING:
    from evdev import InputDevice, InputEvent

INPUT_DIR = Path("/dev/input")
INPUT_GROUP_FIX = "add yourself to the group 'input' (sudo usermod -aG input $USER, log in again)"


def _evdev() -> ModuleType:
    try:
        return importlib.import_module("evdev")
    except ImportError as error:
        raise HardwareError(
            f"--gamepad needs the evdev package (Linux only), which cannot be imported"
            f" ({error}): pip install 'bywire[gamepad]'"
        ) from None


def open_gamepad(path: Path | None) -> InputDevice[str]:
    """The gamepad at ``path``, or the first device in /dev/input that has one's controls."""
    evdev = _evdev()
    if path is None:
        return _first_gamepad(evdev)
    try:
        device: InputDevice[str] = evdev.InputDevice(str(path))
    except FileNotFoundError:
        raise HardwareError(
            f"no gamepad at {path}: the file does not exist; list the devices with"
            f" `python -m evdev.evtest` or `ls -l /dev/input/by-id/`"
        ) from None
    except PermissionError:
        raise HardwareError(
            f"cannot read the gamepad {path}: permission denied; {INPUT_GROUP_FIX}"
        ) from None
    except OSError as error:
        raise HardwareError(
            f"cannot open the gamepad {path}: {error.strerror or error}; is it an event device"
            f" (/dev/input/eventN)?"
        ) from None
    return device


def _first_gamepad(evdev: ModuleType) -> InputDevice[str]:
    """The first event device with a gamepad's controls; unreadable ones are named in the error
    (evdev's own ``list_devices`` would leave them out silently)."""
    unreadable = []
    for path in sorted(INPUT_DIR.glob("event*"), key=lambda p: (len(p.name), p.name)):
        try:
            device: InputDevice[str] = evdev.InputDevice(str(path))
        except PermissionError:
            unreadable.append(path)
            continue
        except OSError:
            continue  # not an input device, or gone since the listing
        if is_gamepad(device.capabilities()):
            return device
        device.close()
    if unreadable:
        raise HardwareError(
            f"no readable gamepad in {INPUT_DIR}: permission denied on {unreadable[0]}"
            + (f" and {len(unreadable) - 1} more" if len(unreadable) > 1 else "")
            + f"; {INPUT_GROUP_FIX}"
        )
    raise HardwareError(
        f"no gamepad found in {INPUT_DIR}: plug one in, or name it: --gamepad /dev/input/eventN"
    )


def is_gamepad(capabilities: dict[int, list[int]]) -> bool:
    """Whether a device's capabilities include a gamepad's buttons and a stick."""
    from evdev import ecodes  # noqa: PLC0415 -- evdev is imported only with --gamepad

    keys = set(capabilities.get(ecodes.EV_KEY, []))
    axes = {
        entry[0] if isinstance(entry, tuple) else entry
        for entry in capabilities.get(ecodes.EV_ABS, [])
    }
    return ecodes.BTN_GAMEPAD in keys and ecodes.ABS_X in axes


def initial_pad(device: InputDevice[str]) -> PadState:
    """The pad's axis ranges and current values, read from the device (``EVIOCGABS``)."""
    from evdev import ecodes  # noqa: PLC0415

    ranges: dict[int, AxisRange] = {}
    values: dict[int, int] = {}
    for code in device.capabilities(absinfo=False).get(ecodes.EV_ABS, []):
        info = device.absinfo(code)
        ranges[code] = AxisRange(info.min, info.max, info.flat)
        values[code] = info.value
    return PadState(ranges=ranges, values=values)


class GamepadReader:
    """Polls an opened device without blocking; after the device goes away, ``lost`` is set."""

    def __init__(self, device: InputDevice[str]) -> None:
        self.device = device
        self.lost: str | None = None

    @property
    def name(self) -> str:
        """The device's name and path, for the status line."""
        return f"{self.device.name} ({os.fsdecode(self.device.path)})"

    def poll(self) -> list[InputEvent]:
        """Every event queued since the last call; [] when none, or once the device is lost."""
        if self.lost is not None:
            return []
        try:
            return list(self.device.read())
        except BlockingIOError:
            return []
        except OSError as error:
            if error.errno not in (errno.ENODEV, errno.EIO, errno.EBADF):
                raise
            self.lost = error.strerror or str(error)
            return []

    def close(self) -> None:
        """Let the device go."""
        self.device.close()


class GamepadDriver:
    """The pad as the teleop program sees it: each period, the state after the pad's events."""

    def __init__(self, reader: GamepadReader, pad: PadState) -> None:
        self.reader = reader
        self.pad = pad

    def step(self, state: TeleopState, now_s: float) -> TeleopState:
        """The events since the last period applied to ``state`` (see ``gamepad.step``)."""
        events = self.reader.poll()
        if self.reader.lost is not None and self.pad.connected:
            self.pad = disconnected(self.pad)
        self.pad, state = step(self.pad, state, events, now_s)
        return state

    def status(self) -> str:
        """One line: which pad, and whether its commands pass."""
        if self.reader.lost is not None:
            return f"gamepad LOST ({self.reader.lost}): full brake; restart teleop to use it again"
        held = "held: driving" if self.pad.dead_man else "released: full brake"
        locked = "  (throttle: release the trigger first)" if self.pad.throttle_locked else ""
        return f"gamepad {self.reader.name}  dead man {held}{locked}"

    def close(self) -> None:
        """Let the device go."""
        self.reader.close()


def open_driver(path: Path | None) -> GamepadDriver:
    """Open the pad (HardwareError naming the fix) and read its axes' ranges and values."""
    device = open_gamepad(path)
    return GamepadDriver(GamepadReader(device), initial_pad(device))
