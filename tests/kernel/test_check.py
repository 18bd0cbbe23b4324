"""`bywire run --check` against the kernel's devices: present, absent, and without permission."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.hal.linux.bench import GPIO_LABEL, line_names
from tests.kernel import guest

NOBODY = "65534"


@pytest.fixture
def devices() -> Iterator[tuple[guest.Vcan, guest.I2cSim]]:
    vcan = guest.Vcan()
    gpio = guest.GpioSim(GPIO_LABEL, line_names())
    guest.pwm_sim()
    dac = guest.I2cSim()
    try:
        yield vcan, dac
    finally:
        dac.close()
        gpio.close()
        vcan.close()


def _check(config: Path, *user: str) -> subprocess.CompletedProcess[str]:
    bywire = str(Path(sys.executable).with_name("bywire"))
    command = [*user, bywire, "run", "--config", str(config), "--check"]
    return subprocess.run(command, capture_output=True, text=True, check=False, timeout=120)


def _config(folder: Path, text: str) -> Path:
    """The robot file where any user may read it (pytest's tmp_path is its owner's alone)."""
    folder = Path(tempfile.mkdtemp(prefix="bywire-check-"))
    folder.chmod(0o755)
    path = folder / "robot.toml"
    path.write_text(text)
    path.chmod(0o644)
    return path


def test_every_device_present_is_ready(
    tmp_path: Path, devices: tuple[guest.Vcan, guest.I2cSim]
) -> None:
    vcan, dac = devices
    done = _check(_config(tmp_path, guest.robot_config(vcan.name, dac.bus)))
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("ready    ") == 6
    assert "6 of 6 devices ready" in done.stdout
    assert dac.code(0) == 0  # opened at 0 V, never energised


def test_every_absent_device_is_named_with_what_to_do(tmp_path: Path) -> None:
    guest.pwm_sim_gone()
    text = guest.robot_config("vcan-absent", 9).replace(guest.RC_TTY, "/dev/ttyUSB7")
    done = _check(_config(tmp_path, text))
    assert done.returncode == 2
    problems = [line for line in done.stdout.splitlines() if line.startswith("PROBLEM")]
    assert len(problems) == 6, done.stdout
    for expected in (
        f"GPIO: no chip '{GPIO_LABEL}'",
        "/dev/i2c-9 does not exist: enable I2C",
        "PWM: no chip 'bywire-pwm-sim.0'",
        "/dev/ttyUSB7 does not exist",
        "vcan-absent: no such network interface",
    ):
        assert expected in done.stdout, expected


def test_a_user_without_permission_is_told_which_group(
    tmp_path: Path, devices: tuple[guest.Vcan, guest.I2cSim]
) -> None:
    vcan, dac = devices
    config = _config(tmp_path, guest.robot_config(vcan.name, dac.bus))
    nobody = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups"]
    done = _check(config, *nobody)
    assert done.returncode == 2, done.stdout + done.stderr
    for group in ("gpio", "i2c", "dialout"):
        assert f"add the user to group {group}" in done.stdout, group
    assert "ready    CAN bus" in done.stdout  # raw CAN sockets need no privilege
