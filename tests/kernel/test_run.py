"""`bywire run` on the linux backend for seconds at a time, on the kernel's devices, driven from
outside by the simulated transmitter (IBUS on a tty) and computer (frames on vcan), every output
read back from the kernel and judged by the simulator's own expectations."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.model import ControlMode
from bywire.sim.catalog import find_scenario
from tests.kernel.player import play
from tests.kernel.robot import KernelRobot


@pytest.fixture(params=["plain-i2c", "smbus-only"])
def robot(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[KernelRobot]:
    made = KernelRobot(tmp_path, dac=request.param)
    try:
        made.start()
        yield made
    finally:
        made.close()


def test_the_test_course_on_the_kernels_devices(robot: KernelRobot) -> None:
    played = play(robot, find_scenario("test-course"))
    assert not played.failed, "\n".join(played.failed)
    assert len(played.passed) >= 4, played.passed  # the speed-only ones are left out
    assert robot.computer.reports > 0
    assert robot.stop() == 0
    last = robot.observe(0.0)
    assert (last.motors_enabled, last.ebrake_engaged, last.throttle_volts) == (False, True, 0.0)
    assert robot.computer.mode is not None
    assert robot.computer.mode.control_mode is ControlMode.STOP
