"""The chooser's Linux openers: one per device, keyed by a typed name, in the safe order."""

from __future__ import annotations

from pathlib import Path

import pytest

from bywire.config import RobotConfig, parse_config
from bywire.config.tree import ESTOP_DEFAULT_LINE
from bywire.hal.linux import gpio_gpiod
from bywire.hal.linux.clock import LinuxClock
from bywire.hal.opening import Device, LinuxPaths, linux_openers, preflight
from tests.hal.linux import fake_gpiod
from tests.hal.linux.bench import GPIO_LABEL, line_names, make_bench


def test_every_device_has_one_opener_and_the_outputs_open_first() -> None:
    """GPIO lines first (requested low: motors off, e-brake on), then the DAC and the PWMs,
    the inputs last; each device once, by the name `bywire run --check` prints."""
    openers = linux_openers(RobotConfig(backend="linux"), LinuxPaths(), LinuxClock())
    order = [device for device, _ in openers.in_order()]
    assert order == list(Device)
    assert order[0] is Device.GPIO
    assert order[-2:] == [Device.RC_UART, Device.CAN]
    assert len(set(order)) == len(order)


def test_a_linux_file_that_says_nothing_of_an_estop_does_not_open_without_the_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 44: the missing key is the default line `ESTOP`, never "no E-stop": on a board
    without that line the GPIO device does not open (`run` refuses to start, `run --check`
    names the key) until the file names the button's line or says "none"."""
    monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
    bench = make_bench(tmp_path)
    names = [name for name in line_names() if name != ESTOP_DEFAULT_LINE]
    fake_gpiod.make_chip(bench.gpio_chip, GPIO_LABEL, names)
    silent = bench.config_text().replace('[estop]\nline = "none"\n', "")
    paths = LinuxPaths(bench.sysfs, bench.dev)
    problem = dict(preflight(parse_config(silent), paths))[Device.GPIO.value]
    assert problem is not None
    assert "estop.line: no line 'ESTOP'" in problem
    assert dict(preflight(parse_config(bench.config_text()), paths))[Device.GPIO.value] is None
