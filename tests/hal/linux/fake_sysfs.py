"""Temporary sysfs trees as the kernel presents them: PWM chips, an IIO DAC, a CAN netdev.

A PWM channel's files refuse what the kernel's PWM core refuses (`pwm_core_checks`): a plain
file would take any write, and so hid an opening order that a real 6.1 kernel refuses.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any

import pytest

NS_PER_S = 1_000_000_000


def make_pwm_chip(
    sysfs: Path, number: int, device: str, *, npwm: int = 2, exported: tuple[int, ...] = (0, 1)
) -> Path:
    """`class/pwm/pwmchipN` -> `devices/platform/soc/<device>/pwm/pwmchipN`, with a device link."""
    device_dir = sysfs / "devices" / "platform" / "soc" / device
    chip = device_dir / "pwm" / f"pwmchip{number}"
    chip.mkdir(parents=True)
    node = sysfs / "firmware" / "devicetree" / "base" / "soc" / f"pwm@{device.partition('.')[0]}"
    node.mkdir(parents=True, exist_ok=True)
    (device_dir / "of_node").symlink_to(node)
    (chip / "device").symlink_to(device_dir)
    (chip / "npwm").write_text(f"{npwm}\n")
    (chip / "export").write_text("")
    (chip / "unexport").write_text("")
    for channel in exported:
        make_pwm_channel(chip, channel)
    link_dir = sysfs / "class" / "pwm"
    link_dir.mkdir(parents=True, exist_ok=True)
    (link_dir / chip.name).symlink_to(chip)
    return link_dir / chip.name


def make_pwm_channel(chip: Path, channel: int) -> Path:
    """What `echo N > export` makes the kernel create (disabled, period 0)."""
    pwm = chip / f"pwm{channel}"
    pwm.mkdir()
    for name, value in (("period", 0), ("duty_cycle", 0), ("enable", 0)):
        (pwm / name).write_text(f"{value}\n")
    (pwm / "polarity").write_text("normal\n")
    return pwm


PWM_STATE = ("period", "duty_cycle", "enable")


def pwm_core_checks(monkeypatch: pytest.MonkeyPatch) -> None:
    """From now on (for the test), a write to a PWM channel's period, duty_cycle or enable under
    any fake chip is checked as `pwm_apply_state()` in drivers/pwm/core.c checks the state it
    makes: EINVAL when the period is 0 or the duty cycle exceeds the period, nothing changed."""
    write_text = Path.write_text

    def checked(path: Path, data: str, *args: Any, **kwargs: Any) -> int:
        if path.name in PWM_STATE and all((path.parent / name).is_file() for name in PWM_STATE):
            state = {name: int((path.parent / name).read_text()) for name in PWM_STATE}
            state[path.name] = int(data)
            if state["period"] == 0 or state["duty_cycle"] > state["period"]:
                raise OSError(errno.EINVAL, "Invalid argument", str(path))
        return write_text(path, data, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", checked)


def read_pwm(chip: Path, channel: int) -> tuple[int, int, int]:
    """(period_ns, duty_cycle_ns, enable) of one channel."""
    pwm = chip / f"pwm{channel}"
    period_ns, duty_cycle_ns, enable = (
        int((pwm / name).read_text()) for name in ("period", "duty_cycle", "enable")
    )
    return period_ns, duty_cycle_ns, enable


def make_iio_dac(sysfs: Path, number: int, i2c_bus: int, address: int) -> Path:
    """The ti-dac5571 driver's device for a DAC6574 on `i2c_bus` at `address`."""
    client = sysfs / "devices" / "platform" / "soc" / f"i2c-{i2c_bus}" / f"{i2c_bus}-{address:04x}"
    device = client / f"iio:device{number}"
    device.mkdir(parents=True)
    (device / "name").write_text("dac6574\n")
    for channel in range(4):
        (device / f"out_voltage{channel}_raw").write_text("0\n")
        (device / f"out_voltage{channel}_powerdown").write_text("0\n")
        (device / f"out_voltage{channel}_scale").write_text("4.882812500\n")
    links = sysfs / "bus" / "iio" / "devices"
    links.mkdir(parents=True, exist_ok=True)
    (links / device.name).symlink_to(device)
    return links / device.name


def read_iio(device: Path, channel: int) -> int:
    return int((device / f"out_voltage{channel}_raw").read_text())


def make_can_netdev(sysfs: Path, name: str, operstate: str) -> Path:
    netdev = sysfs / "class" / "net" / name
    netdev.mkdir(parents=True)
    (netdev / "operstate").write_text(f"{operstate}\n")
    return netdev
