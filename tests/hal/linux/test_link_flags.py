"""The Linux ports' own failures reach the robot's ErrorReport: the controller runs on the Linux
backends (fake sysfs and GPIO, the RC receiver on a pty, python-can's virtual bus through an
adapter the test can pull), and the higher-level computer reads its reports on that bus.

A pulled CAN adapter is a failed receive (CAN_RX_FAILED), a link down (CAN_BUS_OFF) and failed
re-opens (CAN_OPEN_FAILED): nothing can be reported while it lasts, so the flags are held for
half a second after it and the computer reads them once the adapter is back. A pulled RC
adapter is IBUS_PORT_FAILED while it lasts. A PWM chip that goes away under the loop makes a
task raise: the loop ends, its outputs safe, and the last report says TASK_CRASHED. Waits are
generous bounds, never timing figures.
"""

from __future__ import annotations

import dataclasses
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bywire.config import parse_config
from bywire.error_flags import ErrorFlag
from bywire.errors import HardwareError
from bywire.hal.linux.can_pythoncan import PythonCanPort
from bywire.hal.linux.clock import LinuxClock
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport
from bywire.protocol import dbc
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.timing import Budgets
from tests.hal.linux.unpluggable import Unpluggable
from tests.hal.rigs import DAC_RIGS, LinuxRig

LIMIT_S = 10.0
PORT_FLAGS = ErrorFlag.CAN_BUS_OFF | ErrorFlag.CAN_OPEN_FAILED | ErrorFlag.CAN_RX_FAILED


class RunningRobot:
    """`bywire run`'s controller on the Linux rig, in a thread; the rig's peer is the computer."""

    def __init__(self, rig: LinuxRig) -> None:
        self.rig = rig
        original = rig.hardware.can
        assert isinstance(original, PythonCanPort)
        original.close()
        clock = rig.hardware.clock
        assert isinstance(clock, LinuxClock)
        self.adapter = Unpluggable()
        port = PythonCanPort(
            original.settings, clock.notify_input, clock.now, bus_factory=self.adapter
        )
        self._port = port
        robot = parse_config(rig.bench.config_text())
        hardware = dataclasses.replace(rig.hardware, can=port)
        config = RuntimeConfig.from_robot(robot)
        # Not a timing test: a busy machine's late passes must not latch STOP (TIMING_FAULT)
        # before the faults under test.
        loose = Budgets(pass_budget_s=0.5, write_budget_s=0.25, dac_transfer_budget_s=0.25)
        config = dataclasses.replace(
            config, actuators=dataclasses.replace(config.actuators, budgets=loose)
        )
        self.runtime = Runtime(hardware, config)
        self.mode: ControlMode | None = None
        """The mode of the latest ModeReport the computer read."""
        self.raised: Exception | None = None
        """What `Runtime.run` raised (as `bywire run` would see it), None if nothing."""
        self._thread = threading.Thread(target=self._run, name="controller")
        rig.line.transmitter.set_mode(ControlMode.STOP)  # the operator's starting position
        rig.line.transmitter.set_gear(Gear.FORWARD)
        rig.line.start()
        self._thread.start()

    def _run(self) -> None:
        try:
            self.runtime.run()
        except Exception as error:
            self.raised = error

    def reported(self) -> list[ErrorFlag]:
        """The flags of every ErrorReport the computer read since the last call."""
        error_report, mode_report = dbc.frame_id(ErrorReport), dbc.frame_id(ModeReport)
        flags = []
        for frame_id, data in self.rig.peer_frames():
            if frame_id == error_report:
                report = dbc.decode_report(frame_id, data)
                assert isinstance(report, ErrorReport)
                flags.append(report.flags)
            elif frame_id == mode_report:
                mode = dbc.decode_report(frame_id, data)
                assert isinstance(mode, ModeReport)
                self.mode = mode.control_mode
        return flags

    def wait_for(self, what: str, condition: Callable[[list[ErrorFlag]], bool]) -> None:
        """Until the reports read in one short while satisfy `condition`."""
        deadline_s = time.monotonic() + LIMIT_S
        while time.monotonic() < deadline_s:
            time.sleep(0.05)
            if condition(self.reported()):
                return
        raise AssertionError(f"no {what} within {LIMIT_S} s")

    def ended(self) -> bool:
        """True once the loop has ended (asked to, or by a task raising)."""
        self._thread.join(timeout=LIMIT_S)
        return not self._thread.is_alive()

    def close(self) -> None:
        self.runtime.request_stop()
        self._thread.join(timeout=LIMIT_S)
        self._port.close()


@pytest.fixture
def robot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[RunningRobot]:
    rig = LinuxRig(tmp_path, monkeypatch, DAC_RIGS["linux-smbus2"])
    try:
        running = RunningRobot(rig)
        try:
            yield running
        finally:
            running.close()
    finally:
        rig.close()


def _any(flags: ErrorFlag) -> Callable[[list[ErrorFlag]], bool]:
    return lambda seen: any(flags in one for one in seen)


def _none_of(flags: ErrorFlag) -> Callable[[list[ErrorFlag]], bool]:
    return lambda seen: bool(seen) and not any(flags & one for one in seen)


def test_a_pulled_can_adapter_is_reported_once_it_is_back(robot: RunningRobot) -> None:
    robot.wait_for("reports without port flags", _none_of(PORT_FLAGS))
    robot.adapter.plugged = False
    deadline_s = time.monotonic() + LIMIT_S
    while robot._port.link.reopen_failures < 2 and time.monotonic() < deadline_s:
        time.sleep(0.05)  # the port tries to open it again, and fails
    robot.adapter.plugged = True
    robot.wait_for("CAN_BUS_OFF, CAN_OPEN_FAILED and CAN_RX_FAILED", _any(PORT_FLAGS))
    robot.wait_for("the flags cleared", _none_of(PORT_FLAGS))


def test_a_pulled_rc_adapter_is_ibus_port_failed_while_it_lasts(robot: RunningRobot) -> None:
    robot.wait_for("reports without IBUS_PORT_FAILED", _none_of(ErrorFlag.IBUS_PORT_FAILED))
    robot.rig.line.unplug()
    robot.wait_for("IBUS_PORT_FAILED", _any(ErrorFlag.IBUS_PORT_FAILED))
    robot.wait_for("IBUS_PORT_FAILED still up", _any(ErrorFlag.IBUS_PORT_FAILED))
    robot.rig.line.plug()
    robot.wait_for("IBUS_PORT_FAILED cleared", _none_of(ErrorFlag.IBUS_PORT_FAILED))


def test_a_task_that_raises_ends_the_loop_safe_and_its_last_report_says_task_crashed(
    robot: RunningRobot,
) -> None:
    robot.wait_for("reports without TASK_CRASHED", _none_of(ErrorFlag.TASK_CRASHED))
    robot.rig.line.transmitter.set_mode(ControlMode.RC)
    robot.wait_for("RC mode", lambda _: robot.mode is ControlMode.RC)
    # The hydraulic brake's PWM channel disappears (its chip unbound); the switch back to STOP
    # applies the brake: that write raises in the loop's task.
    shutil.rmtree(robot.rig.bench.pwm_chip / "pwm1")
    robot.rig.line.transmitter.set_mode(ControlMode.STOP)
    assert robot.ended()
    assert isinstance(robot.raised, HardwareError)
    assert "PWM hydrobrake" in str(robot.raised)
    assert robot.runtime.crashed_by is robot.raised
    assert not robot.rig.level("motors_enable")
    assert robot.rig.dac_code(0) == robot.rig.dac_code(1) == 0
    last = robot.reported()
    assert last
    assert ErrorFlag.TASK_CRASHED in last[-1]
    assert not any(ErrorFlag.TASK_CRASHED in flags for flags in last[:-1])
