"""The whole decision: arming, RC and CAN driving, timeouts to STOP, lights and flags."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import pytest

from bywire.control.controller import (
    ControlInputs,
    ControlOutputs,
)
from bywire.control.drive import SAFE_DRIVE
from bywire.control.error_flags import ErrorFlag
from bywire.control.rc_mapping import RcRequest
from bywire.control.supervisor import Cause
from bywire.control.validity import Stamped
from bywire.model import ControlCommand, ControlMode, Gear, LightsCommand, MovementCommand
from tests.control.stepping import run

RC_STOP = RcRequest(ControlMode.STOP, 0.0, 0.0, 0.0, Gear.FORWARD, low_beam=False, hazard=False)


def rc_at(at_s: float, **changes: object) -> Stamped[RcRequest | None]:
    return Stamped(replace(RC_STOP, **changes), received_at=at_s)  # type: ignore[arg-type]


def armed_rc(now: float, **changes: object) -> list[tuple[float, ControlInputs]]:
    """Switch in STOP, then the given RC request, 10 ms apart."""
    return [
        (now, ControlInputs(rc=rc_at(now))),
        (now + 0.01, ControlInputs(rc=rc_at(now + 0.01, **changes))),
    ]


def assert_safe(outputs: ControlOutputs) -> None:
    assert outputs.mode is ControlMode.STOP
    assert outputs.drive == SAFE_DRIVE
    assert outputs.ebrake_engaged
    assert outputs.hydrobrake_duty == 1.0


def test_power_up_with_no_input_is_stop_with_every_output_safe() -> None:
    (outputs,) = run([(0.0, ControlInputs())])
    assert_safe(outputs)
    assert outputs.causes == {Cause.POWER_UP, Cause.RC_LOST}
    assert outputs.error_flags & ErrorFlag.RC_TIMEOUT
    assert outputs.steering_pulse_s == pytest.approx(0.0015)


def held(
    first_s: float, duration_s: float, inputs: Callable[[float], ControlInputs]
) -> list[tuple[float, ControlInputs]]:
    """The same input, refreshed every 10 ms for `duration_s` (the throttle ramps up meanwhile)."""
    return [
        (first_s + tick * 0.01, inputs(first_s + tick * 0.01))
        for tick in range(int(duration_s * 100) + 1)
    ]


def test_rc_drives_after_arming_through_stop() -> None:
    def driving(now: float) -> ControlInputs:
        return ControlInputs(
            rc=rc_at(now, mode=ControlMode.RC, throttle_norm=0.5, steering_norm=0.5)
        )

    outputs = run([*armed_rc(0.0, mode=ControlMode.RC), *held(0.02, 0.6, driving)])
    first, last = outputs[2], outputs[-1]
    # the slew limit ramps the throttle at 1.0 /s from the last step in RC (t = 0.01 s)
    assert first.drive.throttle_volts == pytest.approx(0.01 * 5.0)
    assert outputs[12].drive.throttle_volts == pytest.approx(0.11 * 5.0)
    assert last.mode is ControlMode.RC
    assert last.drive.enable
    assert last.drive.forward
    assert last.drive.throttle_volts == pytest.approx(2.5)
    assert not last.ebrake_engaged
    assert last.hydrobrake_duty == 0.0
    assert last.steering_pulse_s > 0.0015


def test_rc_without_passing_through_stop_stays_stop() -> None:
    (outputs,) = run([(0.0, ControlInputs(rc=rc_at(0.0, mode=ControlMode.RC)))])
    assert_safe(outputs)
    assert outputs.causes == {Cause.POWER_UP}


def test_can_drives_in_can_mode() -> None:
    movement = MovementCommand(-0.4, 0.6, 0.0, Gear.REVERSE, counter=3)

    def driving(now: float) -> ControlInputs:
        return ControlInputs(rc=rc_at(now, mode=ControlMode.CAN), movement=Stamped(movement, now))

    def handed_over(now: float) -> ControlInputs:
        idle = replace(movement, throttle_norm=0.0)
        return ControlInputs(rc=rc_at(now, mode=ControlMode.CAN), movement=Stamped(idle, now))

    # armed with the gear switch in reverse: RC's gear was reverse already, no direction change;
    # the computer is seen at zero throttle before it may apply any (bumpless transfer)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC, gear=Gear.REVERSE),
        (0.02, handed_over(0.02)),
        *held(0.03, 0.7, driving),
    ]
    last = run(steps)[-1]
    assert last.mode is ControlMode.CAN
    assert last.drive.reverse
    assert last.drive.throttle_volts == pytest.approx(3.0)
    assert last.lights.reverse


@pytest.mark.parametrize(("age_s", "mode"), [(0.0999, ControlMode.RC), (0.1001, ControlMode.STOP)])
def test_rc_timeout_boundary(age_s: float, mode: ControlMode) -> None:
    last_frame = rc_at(0.01, mode=ControlMode.RC)
    steps = [*armed_rc(0.0, mode=ControlMode.RC), (0.01 + age_s, ControlInputs(rc=last_frame))]
    assert run(steps)[-1].mode is mode


def test_can_timeout_in_can_mode_is_stop_not_rc() -> None:
    movement = Stamped(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, counter=1), 0.02)
    can_mode = rc_at(0.15, mode=ControlMode.CAN)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), movement=movement)),
        (0.15, ControlInputs(rc=can_mode, movement=movement)),
    ]
    last = run(steps)[-1]
    assert_safe(last)
    assert last.causes == {Cause.CAN_LOST}
    assert last.error_flags & ErrorFlag.CAN_COMMAND_TIMEOUT


def test_implausible_rc_frame_stops_at_once_and_flags_failsafe() -> None:
    steps = [*armed_rc(0.0, mode=ControlMode.RC), (0.02, ControlInputs(rc=Stamped(None, 0.02)))]
    last = run(steps)[-1]
    assert_safe(last)
    assert last.error_flags & ErrorFlag.RC_FAILSAFE
    assert not last.error_flags & ErrorFlag.RC_TIMEOUT
    assert last.lights.error_led


def test_remote_stop_over_can() -> None:
    stop = Stamped(ControlCommand(remote_stop=True, re_enable=False, counter=0), 0.02)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), control=stop)),
    ]
    last = run(steps)[-1]
    assert_safe(last)
    assert last.causes == {Cause.REMOTE_STOP}


def test_hardware_fault_stops() -> None:
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (
            0.02,
            ControlInputs(
                rc=rc_at(0.02, mode=ControlMode.RC),
                dac_failing=True,
                fault_flags=int(ErrorFlag.DAC_FAULT_STOP),
            ),
        ),
    ]
    last = run(steps)[-1]
    assert_safe(last)
    assert last.error_flags & ErrorFlag.DAC_FAULT_STOP


def test_can_lights_apply_in_can_mode_only() -> None:
    lights = Stamped(
        LightsCommand(turn_left=True, turn_right=False, hazard=False, low_beam=True, counter=0),
        0.02,
    )
    movement = Stamped(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, counter=1), 0.02)
    can_steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (
            0.02,
            ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), movement=movement, lights=lights),
        ),
    ]
    assert run(can_steps)[-1].lights.low_beam
    assert run(can_steps)[-1].lights.turn_left  # blink phase is on at t = 0.02 s
    rc_steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), lights=lights)),
    ]
    assert not run(rc_steps)[-1].lights.low_beam


def test_rc_low_beam_and_hazard_in_rc_mode() -> None:
    last = run(armed_rc(0.0, mode=ControlMode.RC, low_beam=True, hazard=True))[-1]
    assert last.lights.low_beam
    assert last.lights.turn_left
    assert last.lights.turn_right


def test_steering_holds_in_stop() -> None:
    steer = [
        *armed_rc(0.0, mode=ControlMode.RC),
        *[
            (
                0.02 + 0.01 * tick,
                ControlInputs(rc=rc_at(0.02 + 0.01 * tick, mode=ControlMode.RC, steering_norm=0.6)),
            )
            for tick in range(50)
        ],
    ]
    then_stop = [(0.6, ControlInputs(rc=rc_at(0.6))), (0.7, ControlInputs(rc=rc_at(0.7)))]
    outputs = run(steer + then_stop)
    assert outputs[-3].steering_pulse_s == pytest.approx(0.0018)
    assert outputs[-1].steering_pulse_s == pytest.approx(0.0018)
    assert outputs[-1].mode is ControlMode.STOP


def test_brake_from_rc_drives_regen_hydro_and_brake_lights() -> None:
    last = run(armed_rc(0.0, mode=ControlMode.RC, brake_norm=0.8))[-1]
    assert last.mode is ControlMode.RC
    assert last.drive.regen_volts == pytest.approx(4.0)
    assert last.hydrobrake_duty == pytest.approx(0.6)
    assert last.lights.brake


@pytest.mark.parametrize(("age_s", "mode"), [(0.0999, ControlMode.CAN), (0.1001, ControlMode.STOP)])
def test_can_timeout_boundary_in_can_mode(age_s: float, mode: ControlMode) -> None:
    movement = MovementCommand(0.0, 0.0, 0.2, Gear.FORWARD, counter=1)
    sent = Stamped(movement, 0.02)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), movement=sent)),
        (0.02 + age_s, ControlInputs(rc=rc_at(0.02 + age_s, mode=ControlMode.CAN), movement=sent)),
    ]
    assert run(steps)[-1].mode is mode
