"""Faults the kernel makes, on `bywire run` driving by CAN: each ends with the outputs safe on
the kernel's devices (motors disabled, 0 V, e-brake engaged), the right flag in the robot's
ErrorReport, and a log line that names the real cause.

The robot and the computer sit on the two ends of a vxcan pair, so a qdisc on one end acts
between them as on a wire. The ports' own failures (a CAN link down, an RC line gone) reach the
ErrorReport through their `link` (CAN_BUS_OFF, IBUS_PORT_FAILED); a loop that a task's exception
ends says TASK_CRASHED in its last report; a DAC that stops answering is named in the log with
the kernel's own words.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from tests.kernel import guest
from tests.kernel.robot import KernelRobot

SAFE_WITHIN_S = 5.0  # the tier's input timeouts are 1 s (guest.robot_config)


@pytest.fixture
def robot(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[KernelRobot]:
    closes_rc = "rc_line_that_closes" in request.node.name
    made = KernelRobot(tmp_path, rc_tty=guest.RC_TTY_TO_CLOSE if closes_rc else guest.RC_TTY)
    try:
        made.start()
        yield made
    finally:
        made.close()


def drive_by_can(robot: KernelRobot) -> None:
    """Arm (the switch through STOP), hand over to CAN, and let the computer drive."""
    robot.computer.apply("hlc", {"throttle": 0.0, "brake": 0.5, "gear": "forward"})
    robot.transmitter.apply({"mode": "stop", "gear": "forward", "throttle": 0.0})
    time.sleep(0.5)
    robot.transmitter.apply({"mode": "can"})
    robot.wait_for("CAN mode", lambda: _mode(robot) is ControlMode.CAN, SAFE_WITHIN_S)
    robot.computer.apply("hlc", {"throttle": 0.4, "brake": 0.0})
    robot.wait_for("throttle on the DAC", lambda: robot.observe(0.0).throttle_volts > 0.5, 5.0)


def _mode(robot: KernelRobot) -> ControlMode | None:
    report = robot.computer.mode
    return None if report is None else report.control_mode


def outputs_safe(robot: KernelRobot) -> bool:
    """Safe as the kernel's devices hold them (the mode is the robot's word, so not asked)."""
    seen = robot.observe(0.0)
    return not seen.motors_enabled and seen.ebrake_engaged and seen.throttle_volts == 0.0


def flags(robot: KernelRobot) -> ErrorFlag:
    report = robot.computer.errors
    return ErrorFlag(0) if report is None else report.flags


def wait_safe(robot: KernelRobot) -> None:
    robot.wait_for("safe outputs", lambda: outputs_safe(robot), SAFE_WITHIN_S)


def wait_flag(robot: KernelRobot, flag: ErrorFlag) -> None:
    robot.wait_for(f"{flag.name} reported", lambda: flag in flags(robot), SAFE_WITHIN_S)


def test_can_link_down_stops_the_robot_and_up_brings_its_reports_back(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.set_up(False)
    wait_safe(robot)
    robot.wait_for("the cause in the log", lambda: "Network is down" in robot.log())
    robot.vcan.set_up(True)
    wait_flag(robot, ErrorFlag.CAN_COMMAND_TIMEOUT)
    assert robot.computer.mode is not None
    assert robot.computer.mode.stop_latched
    assert outputs_safe(robot)


def test_can_link_down_raises_can_bus_off(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.set_up(False)
    wait_safe(robot)
    robot.vcan.set_up(True)
    wait_flag(robot, ErrorFlag.CAN_BUS_OFF)


def test_a_full_transmit_queue_is_flagged_and_never_starves_the_robot(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.qdisc("plug", "limit", "4")  # the robot's reports stop in its queue: ENOBUFS
    robot.vcan.qdisc("plug", "block")
    time.sleep(1.5)
    assert robot.observe(0.0).throttle_volts > 0.5  # commands still arrive: it drives on (§5.2)
    robot.vcan.qdisc("pfifo_fast")
    wait_flag(robot, ErrorFlag.CAN_TX_FAILED)
    assert _mode(robot) is ControlMode.CAN


def test_commands_lost_on_the_wire_stop_the_robot(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.qdisc("netem", "loss", "100%", on=robot.vcan.peer)  # the computer's side
    wait_safe(robot)
    robot.vcan.qdisc("pfifo_fast", on=robot.vcan.peer)
    wait_flag(robot, ErrorFlag.CAN_COMMAND_TIMEOUT)


def test_commands_delayed_within_the_timeout_keep_the_robot_driving(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.qdisc("netem", "delay", "300ms", on=robot.vcan.peer)
    time.sleep(2.0)
    assert _mode(robot) is ControlMode.CAN
    assert robot.observe(0.0).throttle_volts > 0.5


def test_commands_delayed_past_the_timeout_stop_the_robot(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.vcan.qdisc("netem", "delay", "1500ms", on=robot.vcan.peer)
    wait_safe(robot)
    robot.vcan.qdisc("pfifo_fast", on=robot.vcan.peer)
    wait_flag(robot, ErrorFlag.CAN_COMMAND_TIMEOUT)


def test_a_bus_off_error_frame_is_logged_as_bus_off(robot: KernelRobot) -> None:
    drive_by_can(robot)
    with can.Bus(interface="socketcan", channel=robot.vcan.peer) as other:
        other.send(can.Message(arbitration_id=0x40, is_error_frame=True, dlc=8, data=bytes(8)))
    robot.wait_for("bus-off in the log", lambda: "bus-off" in robot.log(), SAFE_WITHIN_S)


def test_a_dac_that_stops_answering_stops_the_robot(robot: KernelRobot) -> None:
    drive_by_can(robot)
    assert isinstance(robot.dac, guest.I2cSim)
    robot.dac.set_present(False)
    robot.wait_for(
        "motors disabled and e-brake engaged",
        lambda: not robot.observe(0.0).motors_enabled and robot.observe(0.0).ebrake_engaged,
        SAFE_WITHIN_S,
    )
    wait_flag(robot, ErrorFlag.DAC_FAULT_STOP)
    assert _mode(robot) is ControlMode.STOP
    robot.dac.set_present(True)


def test_a_dac_that_stops_answering_is_named_in_the_log(robot: KernelRobot) -> None:
    drive_by_can(robot)
    assert isinstance(robot.dac, guest.I2cSim)
    robot.dac.set_present(False)
    wait_flag(robot, ErrorFlag.DAC_FAULT_STOP)
    robot.wait_for("the cause in the log", lambda: "No such device or address" in robot.log())


def test_a_gpio_chip_that_goes_away_leaves_no_throttle_and_says_why(robot: KernelRobot) -> None:
    drive_by_can(robot)
    robot.gpio.close()  # its lines go with it: an expander's pins fall to their pull-downs
    robot.wait_for("0 V on the throttle", lambda: robot.throttle_volts() == 0.0, SAFE_WITHIN_S)
    robot.wait_for("the cause in the log", lambda: "No such device" in robot.log())


def test_a_task_that_raises_ends_safe_and_its_last_report_says_task_crashed(
    robot: KernelRobot,
) -> None:
    drive_by_can(robot)
    robot.gpio.close()  # the next write to a line raises: the loop ends (a task crashed)
    assert robot.process is not None
    robot.process.wait(timeout=SAFE_WITHIN_S)
    assert robot.throttle_volts() == 0.0
    deadline_s = time.monotonic() + SAFE_WITHIN_S  # the last frames, read by the computer
    while ErrorFlag.TASK_CRASHED not in flags(robot) and time.monotonic() < deadline_s:
        time.sleep(0.01)
    assert ErrorFlag.TASK_CRASHED in flags(robot)
    assert robot.computer.mode is not None
    assert robot.computer.mode.control_mode is ControlMode.STOP
    assert "a task raised" in robot.log()


def test_an_rc_line_that_closes_stops_the_robot_by_rc(robot: KernelRobot) -> None:
    robot.transmitter.apply({"mode": "stop", "gear": "forward", "throttle": 0.0})
    time.sleep(0.5)
    robot.transmitter.apply({"mode": "rc"})  # armed with the stick at zero
    robot.wait_for("RC mode", lambda: _mode(robot) is ControlMode.RC, SAFE_WITHIN_S)
    robot.transmitter.apply({"throttle": 0.5})
    robot.wait_for("RC drives", lambda: robot.observe(0.0).throttle_volts > 0.3, SAFE_WITHIN_S)
    robot.transmitter.sending = False
    robot.host.close_rc()
    wait_safe(robot)
    wait_flag(robot, ErrorFlag.RC_TIMEOUT)
    assert _mode(robot) is ControlMode.STOP


def test_an_rc_line_that_closes_raises_ibus_port_failed(robot: KernelRobot) -> None:
    robot.transmitter.sending = False
    robot.host.close_rc()
    wait_flag(robot, ErrorFlag.IBUS_PORT_FAILED)
