"""Issue 44 on the kernel's devices: the E-stop pressed through gpio-sim drops the enable line.

`bywire run` holds the E-stop's line of a gpio-sim chip as an input, pulled down; the test
closes the button's circuit (gpio-sim's pull up) once it runs, drives by RC, then presses
(pull down): the motors' enable line goes low and the e-brake engages, as gpio-sim holds them,
ESTOP_PRESSED is reported, and releasing the button alone does not re-enable; the switch
through STOP does.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.config.tree import ESTOP_DEFAULT_LINE
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from tests.kernel.robot import KernelRobot
from tests.kernel.test_faults import (
    SAFE_WITHIN_S,
    _mode,
    flags,
    outputs_safe,
    wait_flag,
    wait_safe,
)


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[KernelRobot]:
    made = KernelRobot(tmp_path, estop_line=ESTOP_DEFAULT_LINE)
    try:
        made.start()
        yield made
    finally:
        made.close()


def _drive_by_rc(robot: KernelRobot) -> None:
    robot.transmitter.apply({"mode": "stop", "gear": "forward", "throttle": 0.0})
    time.sleep(0.5)
    robot.transmitter.apply({"mode": "rc"})  # armed with the stick at zero
    robot.wait_for("RC mode", lambda: _mode(robot) is ControlMode.RC, SAFE_WITHIN_S)
    robot.transmitter.apply({"throttle": 0.4})
    robot.wait_for("the motors enabled", lambda: robot.observe(0.0).motors_enabled, SAFE_WITHIN_S)


def test_the_estop_pressed_through_gpio_sim_drops_the_enable_line(robot: KernelRobot) -> None:
    _drive_by_rc(robot)
    assert not robot.observe(0.0).ebrake_engaged
    robot.gpio.set_pull(ESTOP_DEFAULT_LINE, up=False)  # pressed: the circuit opens
    robot.wait_for("the enable line low", lambda: not robot.observe(0.0).motors_enabled, 1.0)
    wait_safe(robot)
    wait_flag(robot, ErrorFlag.ESTOP_PRESSED)
    robot.gpio.set_pull(ESTOP_DEFAULT_LINE, up=True)  # released; the switch still at RC
    time.sleep(1.0)
    assert outputs_safe(robot)
    assert robot.computer.mode is not None
    assert robot.computer.mode.control_mode is ControlMode.STOP
    assert ErrorFlag.ESTOP_PRESSED in flags(robot)  # latched
    _drive_by_rc(robot)  # released and the switch through STOP: driving again
