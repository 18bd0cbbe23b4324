"""Sysfs PWM on a temporary tree: chips by device name, node or path; period, duty and enable in
nanoseconds; export of a new channel; safe close. The tree refuses what the kernel's PWM core
refuses (`pwm_core_checks`); tests/kernel runs the same backend on a real 6.1 kernel."""

from __future__ import annotations

import errno
import threading
from pathlib import Path

import pytest

from bywire.errors import HardwareError
from bywire.hal.linux.pwm_sysfs import SysfsPwm, find_pwm_chip
from tests.hal.linux.fake_sysfs import make_pwm_channel, make_pwm_chip, pwm_core_checks, read_pwm


@pytest.fixture
def sysfs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    make_pwm_chip(tmp_path, 0, "fe804000.pwm-other", exported=())
    make_pwm_chip(tmp_path, 2, "fe20c000.pwm")
    pwm_core_checks(monkeypatch)
    return tmp_path


@pytest.mark.parametrize(
    "spec",
    [
        "fe20c000.pwm",
        "pwm@fe20c000",
        "pwmchip2",
        "platform/soc/fe20c000.pwm",
        "SYSFS/devices/platform/soc/fe20c000.pwm",
    ],
)
def test_a_chip_is_found_by_its_device_not_its_number(sysfs: Path, spec: str) -> None:
    assert find_pwm_chip(sysfs, spec.replace("SYSFS", str(sysfs))).name == "pwmchip2"


def test_a_chip_directory_may_be_given_as_a_path(sysfs: Path) -> None:
    chip = sysfs / "class" / "pwm" / "pwmchip2"
    assert find_pwm_chip(sysfs / "elsewhere", str(chip)) == chip


def test_an_unknown_chip_lists_the_chips_there_are(sysfs: Path) -> None:
    with pytest.raises(
        HardwareError, match=r"no chip '1f00098000.pwm' \(found: pwmchip0 = fe804000"
    ):
        find_pwm_chip(sysfs, "1f00098000.pwm")


def test_opening_sets_the_period_with_the_line_low_then_pulses_in_ns(sysfs: Path) -> None:
    chip = find_pwm_chip(sysfs, "fe20c000.pwm")
    pwm = SysfsPwm(chip, 0, 0.020, "steering.pwm")
    assert read_pwm(chip, 0) == (20_000_000, 0, 1)
    pwm.set_pulse(0.0015)
    assert read_pwm(chip, 0) == (20_000_000, 1_500_000, 1)
    with pytest.raises(HardwareError, match=r"steering.pwm: pulse 0.03 s is outside 0..0.02 s"):
        pwm.set_pulse(0.030)
    pwm.close()
    pwm.close()
    assert read_pwm(chip, 0) == (20_000_000, 0, 0)


def test_a_channel_not_yet_exported_is_exported(sysfs: Path) -> None:
    chip = find_pwm_chip(sysfs, "fe804000.pwm-other")
    kernel = threading.Timer(0.05, make_pwm_channel, (chip, 1))  # what the kernel does on export
    kernel.start()
    pwm = SysfsPwm(chip, 1, 0.001)
    kernel.join()
    assert (chip / "export").read_text() == "1"
    assert read_pwm(chip, 1) == (1_000_000, 0, 1)
    pwm.close()


def test_an_export_that_makes_no_channel_says_so(sysfs: Path) -> None:
    chip = find_pwm_chip(sysfs, "fe804000.pwm-other")
    with pytest.raises(HardwareError, match="made no pwm5: check the channel number"):
        SysfsPwm(chip, 5, 0.001)


def test_the_tree_refuses_what_the_pwm_core_refuses(sysfs: Path) -> None:
    channel = find_pwm_chip(sysfs, "fe20c000.pwm") / "pwm0"
    with pytest.raises(OSError, match="Invalid argument") as refused:
        (channel / "duty_cycle").write_text("0")  # a fresh channel: period 0
    assert refused.value.errno == errno.EINVAL
    (channel / "period").write_text("1000")
    with pytest.raises(OSError, match="Invalid argument"):
        (channel / "duty_cycle").write_text("1001")
    assert (channel / "duty_cycle").read_text().strip() == "0"


def test_a_fresh_channel_gets_its_period_before_its_duty_cycle(sysfs: Path) -> None:
    # The kernel's EINVAL on duty_cycle with period 0 stopped the robot's PWM opening (6.1).
    chip = find_pwm_chip(sysfs, "fe20c000.pwm")
    assert read_pwm(chip, 1) == (0, 0, 0)
    pwm = SysfsPwm(chip, 1, 0.001, "hydrobrake.pwm")
    assert read_pwm(chip, 1) == (1_000_000, 0, 1)
    pwm.close()


def test_a_channel_left_with_a_long_duty_cycle_opens_at_a_shorter_period(sysfs: Path) -> None:
    chip = find_pwm_chip(sysfs, "fe20c000.pwm")
    left = SysfsPwm(chip, 0, 0.020)
    left.set_pulse(0.0015)  # then the process dies: the channel keeps 20 ms / 1.5 ms
    pwm = SysfsPwm(chip, 0, 0.001)
    assert read_pwm(chip, 0) == (1_000_000, 0, 1)
    pwm.close()
