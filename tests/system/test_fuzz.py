"""Property tests on the whole robot: random IBUS bytes and random CAN frames on every 11-bit id
never crash the controller and never move an actuator without a valid command in the selected mode.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bywire.can_frame import CanFrame
from bywire.model import ControlMode
from tests.system.harness import Robot

frames = st.lists(
    st.tuples(
        st.floats(0.0, 0.5),
        st.integers(0, 0x7FF),
        st.binary(max_size=8),
    ),
    max_size=60,
)
byte_bursts = st.lists(
    st.tuples(st.floats(0.0, 0.5), st.binary(min_size=1, max_size=64)), max_size=20
)
FUZZ = settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow])


def _dropping_result(action: Callable[[], object]) -> Callable[[], None]:
    """`action` as a timer callback, which returns nothing."""

    def run() -> None:
        action()

    return run


def spammed(robot: Robot, can_frames: list[tuple[float, int, bytes]]) -> None:
    """A rogue node sends these frames; the controller's acceptance filter is opened wide."""
    rogue = robot.world.bus.attach("rogue", tx_mailboxes=len(can_frames) + 1)
    robot.world.controller_can.set_filter(None)
    for at_s, frame_id, data in can_frames:
        robot.at(at_s, _dropping_result(partial(rogue.send, CanFrame(frame_id, data))))


@FUZZ
@given(can_frames=frames, bursts=byte_bursts)
def test_noise_alone_never_moves_an_actuator(
    can_frames: list[tuple[float, int, bytes]], bursts: list[tuple[float, bytes]]
) -> None:
    robot = Robot.build()
    spammed(robot, can_frames)
    for at_s, data in bursts:
        robot.at(at_s, _dropping_result(partial(robot.world.uart.transmit, data)))
    robot.world.start(rc=False, hlc=False)
    robot.runtime.run(until_s=0.6)
    gpio = robot.world.gpio
    assert not any(level for _, level in gpio["motors_enable"].history)
    assert not any(level for _, level in gpio["ebrake_release"].history)
    assert all(volts == 0.0 for _, channel, volts in robot.world.dac.history if channel == 0)
    assert {pulse for _, pulse in robot.world.pwm.steering.history} == {0.0015}
    assert [mode for _, mode in robot.runtime.mode_log] == [ControlMode.STOP]


@FUZZ
@given(can_frames=frames)
def test_can_noise_never_changes_what_rc_drives(can_frames: list[tuple[float, int, bytes]]) -> None:
    robot = Robot.build()
    robot.arm_rc(at_s=0.0)
    robot.at(0.15, lambda: robot.world.rc.set_pedal(0.3))
    spammed(robot, [(at_s + 0.2, frame_id, data) for at_s, frame_id, data in can_frames])
    robot.run(0.8)
    assert [mode for _, mode in robot.runtime.mode_log] == [ControlMode.STOP, ControlMode.RC]
    throttle = [volts for _, channel, volts in robot.world.dac.history if channel == 0]
    driving = robot.throttle_volts(0.75)
    assert max(throttle) == driving  # RC's 0.3 throttle after its ramp, never more from CAN
    assert abs(driving - 1.5) < 0.01
