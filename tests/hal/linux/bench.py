"""A whole robot's devices as a Linux test machine can present them, and a config that uses them.

sysfs and /dev live under a temporary root: a PWM chip known by its device name (numbered 2 on
purpose: the configuration must not depend on the number), the ti-dac5571 IIO device of the
DAC6574, file-backed GPIO chips (`fake_gpiod`), the RC receiver on a pty, and a python-can
virtual channel of its own.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bywire.config import RobotConfig, output_lines
from bywire.config.tree import ESTOP_DEFAULT_LINE
from bywire.hal.hardware import OUTPUT_NAMES
from tests.hal.linux import fake_gpiod
from tests.hal.linux.fake_sysfs import make_iio_dac, make_pwm_chip, read_iio, read_pwm

GPIO_LABEL = "bywire-test-gpio"
PWM_DEVICE = "fe20c000.pwm"
DAC_BUS, DAC_ADDRESS = 1, 0x4C


def line_names() -> list[str]:
    """The test GPIO chip's line names: two of another use, then every output's, then the
    E-stop's input (read only by a robot file that names it)."""
    names = [str(line.line) for line in output_lines(RobotConfig()).values()]
    return ["ID_SD", "ID_SC", *names, ESTOP_DEFAULT_LINE]


@dataclass
class Bench:
    """Paths of the stand-ins, and read-back of what the backends wrote to them."""

    root: Path
    sysfs: Path
    dev: Path
    gpio_chip: Path
    pwm_chip: Path
    iio_device: Path | None
    rc_link: Path
    can_channel: str
    can_interface: str = "virtual"

    def config_text(self, **extra: str) -> str:
        text = f"""
name = "bench"
backend = "linux"
gpio_chip = "{GPIO_LABEL}"

[estop]
line = "none"

[can]
interface = "{self.can_interface}"
channel = "{self.can_channel}"

[rc]
port = "{self.rc_link}"

[steering.pwm]
chip = "{PWM_DEVICE}"
channel = 0

[hydrobrake.pwm]
chip = "{PWM_DEVICE}"
channel = 1

[drive.dac]
i2c_bus = {DAC_BUS}
address = 0x{DAC_ADDRESS:02X}

[timeouts]
rc_timeout_s = 0.5
can_command_timeout_s = 0.5
watchdog_s = 2.0
stop_response_s = 0.06       # the stand-ins write files: milliseconds each on a busy machine,
pass_budget_s = 0.05         # so the bench declares the loosest stop promise the loader allows
write_budget_s = 0.02
dac_transfer_budget_s = 0.02
"""
        return text + "".join(f"\n{line}" for line in extra.values())

    def gpio_state(self) -> dict[str, Any]:
        return fake_gpiod.read_state(self.gpio_chip)

    def levels(self) -> dict[str, int]:
        """Level of every output, by its name (`OUTPUT_NAMES`)."""
        by_line = self.gpio_state()["levels"]
        lines = output_lines(RobotConfig())
        return {name: by_line[str(lines[name].line)] for name in OUTPUT_NAMES}

    def pwm(self, channel: int) -> tuple[int, int, int]:
        """(period_ns, duty_cycle_ns, enable)."""
        return read_pwm(self.pwm_chip, channel)

    def dac_code(self, channel: int) -> int:
        if self.iio_device is None:
            raise ValueError("this bench has no IIO DAC")
        return read_iio(self.iio_device, channel)


def make_bench(root: Path, *, iio: bool = True) -> Bench:
    sysfs, dev = root / "sys", root / "dev"
    dev.mkdir(parents=True)
    fake_gpiod.make_chip(dev / "gpiochip0", "other-expander", ["A", "B"])
    gpio_chip = fake_gpiod.make_chip(dev / "gpiochip1", GPIO_LABEL, line_names())
    pwm_chip = make_pwm_chip(sysfs, 2, PWM_DEVICE)
    iio_device = make_iio_dac(sysfs, 0, DAC_BUS, DAC_ADDRESS) if iio else None
    return Bench(
        root,
        sysfs,
        dev,
        gpio_chip,
        pwm_chip,
        iio_device,
        root / "ttyRC",
        f"bywire-test-{uuid.uuid4().hex[:8]}",
    )
