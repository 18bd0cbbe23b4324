"""PWM through `/sys/class/pwm`: the chip found by label or device, never by its number.

A chip is given as `pwmchipN`, as a path to its sysfs directory, or (what survives kernel
updates) as its device's name (`1f00098000.pwm`), device-tree node (`pwm@7e20c000`) or a tail
of its device path. Opening exports the channel if needed, sets the period with the duty cycle
at 0 and enables the output: the line stays low until the first pulse is set. Times in sysfs are
integer nanoseconds; every write is checked by the kernel's PWM core, which refuses a period of
0 or a duty cycle longer than the period, so the order of the writes matters.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

from bywire.errors import HardwareError
from bywire.hal.linux.device_errors import device_error, reason

NS_PER_S = 1_000_000_000
EXPORT_WAIT_S = 1.0  # udev sets the new channel's permissions just after the export
MISSING_HINT = "enable the PWM overlay (Raspberry Pi: dtoverlay=pwm-2chan) or fix the chip key"


def find_pwm_chip(sysfs_root: Path, spec: str) -> Path:
    """The sysfs directory of the PWM chip `spec`; HardwareError listing the chips otherwise."""
    if (Path(spec) / "npwm").is_file():
        return Path(spec)
    chips = sorted((sysfs_root / "class" / "pwm").glob("pwmchip*"))
    for chip in chips:
        identities = _identities(chip)
        if spec in (chip.name, *identities) or identities[-1].endswith("/" + spec.lstrip("/")):
            return chip
    found = ", ".join(f"{chip.name} = {_identities(chip)[0]}" for chip in chips) or "none"
    raise HardwareError(f"PWM: no chip {spec!r} (found: {found}): {MISSING_HINT}")


def _identities(chip: Path) -> tuple[str, ...]:
    """Stable names of a chip: device name, device-tree node, full device path."""
    device = (chip / "device").resolve()
    node = (chip / "device" / "of_node").resolve()
    names = [device.name, node.name] if node.exists() else [device.name]
    return (*names, str(device))


class SysfsPwm:
    """A `PwmChannel` on `chip`/`pwm<channel>` with a fixed period."""

    def __init__(self, chip: Path, channel: int, period_s: float, name: str = "") -> None:
        if not 0.0 < period_s < 1.0:
            raise HardwareError(f"PWM {name}: period {period_s} s is outside 0..1 s")
        self.name = name or f"{chip.name}/pwm{channel}"
        self._period_s = period_s
        self._period_ns = round(period_s * NS_PER_S)
        self._dir = chip / f"pwm{channel}"
        self._closed = False
        self._opening = True  # only while opening may a write wait for udev
        self._duty_ns: int | None = None
        if not self._dir.is_dir():
            self._export(chip, channel)
        # The PWM core refuses any state with period 0 or duty > period (EINVAL). A fresh
        # channel has period 0 (drivers without get_state, e.g. pwm-bcm2835): period first.
        # A channel left with a period may hold a duty longer than ours: duty 0 first there.
        if self._read("period") != 0:
            self._write("duty_cycle", 0)
        self._write("period", self._period_ns)
        self._write("duty_cycle", 0)
        self._write("enable", 1)
        self._opening = False

    @property
    def period_s(self) -> float:
        return self._period_s

    def set_pulse(self, pulse_s: float) -> None:
        if self._closed:
            raise HardwareError(f"PWM {self.name}: closed")
        if not 0.0 <= pulse_s <= self._period_s:
            raise HardwareError(
                f"PWM {self.name}: pulse {pulse_s} s is outside 0..{self._period_s} s"
            )
        duty_ns = min(round(pulse_s * NS_PER_S), self._period_ns)
        if duty_ns != self._duty_ns:
            self._write("duty_cycle", duty_ns)

    def close(self) -> None:
        """Duty 0 and disabled: the line low, as de-energised; safe to call again."""
        if self._closed:
            return
        self._closed = True
        for attribute in ("duty_cycle", "enable"):
            with contextlib.suppress(HardwareError):  # a chip that is gone drives nothing
                self._write(attribute, 0)

    def _export(self, chip: Path, channel: int) -> None:
        try:
            (chip / "export").write_text(str(channel), encoding="ascii")
        except OSError as error:
            raise device_error(
                f"PWM {self.name}", str(chip / "export"), error, group="gpio", missing=MISSING_HINT
            ) from error
        deadline_s = time.monotonic() + EXPORT_WAIT_S
        while not (self._dir / "enable").exists():
            if time.monotonic() > deadline_s:
                raise HardwareError(
                    f"PWM {self.name}: exporting channel {channel} of {chip} made no"
                    f" {self._dir.name}: check the channel number (npwm)"
                )
            time.sleep(0.01)

    def _read(self, attribute: str) -> int | None:
        """The attribute's value, None if it cannot be read (then assume the worst)."""
        try:
            return int((self._dir / attribute).read_text(encoding="ascii"))
        except (OSError, ValueError):
            return None

    def _write(self, attribute: str, value: int) -> None:
        path = self._dir / attribute
        deadline_s = time.monotonic() + EXPORT_WAIT_S
        while True:
            try:
                path.write_text(str(value), encoding="ascii")
            except PermissionError as error:
                if self._opening and time.monotonic() < deadline_s:
                    time.sleep(0.01)  # udev may not have changed the group yet
                    continue
                raise device_error(
                    f"PWM {self.name}", str(path), error, group="gpio", missing=MISSING_HINT
                ) from error
            except OSError as error:
                raise HardwareError(
                    f"PWM {self.name}: writing {value} to {path} failed ({reason(error)})"
                ) from error
            if attribute == "duty_cycle":
                self._duty_ns = value
            return
