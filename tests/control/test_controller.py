"""The whole decision: arming, RC and CAN driving, timeouts to STOP, lights and flags."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any, TypedDict, TypeVar, Unpack

import pytest
from hypothesis import assume, event, given, settings
from hypothesis import strategies as st

from bywire.command_table import COMMANDS, Use, command_row
from bywire.control.command_edges import CommandEdges, command_edges
from bywire.control.command_slots import received
from bywire.control.controller import (
    RULES,
    ControlConfig,
    ControlInputs,
    ControlOutputs,
    ControlState,
    changes_decision,
    check_rules,
    controller_step,
)
from bywire.control.drive import SAFE_DRIVE
from bywire.control.governor import GovernorConfig
from bywire.control.rc_mapping import RcRequest
from bywire.control.sensor_checks import MonitorConfig
from bywire.control.steering import SteeringConfig
from bywire.control.stop import StopPhase
from bywire.control.supervisor import Cause, SupervisorConfig
from bywire.control.validity import Stamped
from bywire.error_flags import ErrorFlag
from bywire.model import (
    LIGHTS_OFF,
    ControlCommand,
    ControlMode,
    Gear,
    LightsCommand,
    MovementCommand,
)
from tests.control.stepping import CONFIG, framed, run

T = TypeVar("T")
RC_STOP = RcRequest(ControlMode.STOP, 0.0, 0.0, 0.0, Gear.FORWARD, low_beam=False, hazard=False)


class RcChanges(TypedDict, total=False):
    """Fields of an `RcRequest` a test changes from `RC_STOP`."""

    mode: ControlMode
    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: Gear
    low_beam: bool
    hazard: bool


def rc_at(at_s: float, **changes: Unpack[RcChanges]) -> Stamped[RcRequest | None]:
    return Stamped(replace(RC_STOP, **changes), received_at=at_s)


def armed_rc(now: float, **changes: Unpack[RcChanges]) -> list[tuple[float, ControlInputs]]:
    """Switch in STOP, then the given RC request, 10 ms apart."""
    return [
        (now, ControlInputs(rc=rc_at(now))),
        (now + 0.01, ControlInputs(rc=rc_at(now + 0.01, **changes))),
    ]


def assert_safe(outputs: ControlOutputs) -> None:
    """STOP: throttle 0 V, both brakes on; the drive off, or (category 1, no speed known yet)
    powered to brake with the regenerative brake at full."""
    assert outputs.mode is ControlMode.STOP
    assert outputs.drive.throttle_volts == 0.0
    assert outputs.drive == SAFE_DRIVE or (
        outputs.stop_phase is StopPhase.BRAKING
        and outputs.drive.regen_volts == CONFIG.drive.max_regen_volts
    )
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
        return ControlInputs(
            rc=rc_at(now, mode=ControlMode.CAN), commands=received(Stamped(movement, now))
        )

    def handed_over(now: float) -> ControlInputs:
        idle = replace(movement, throttle_norm=0.0)
        return ControlInputs(
            rc=rc_at(now, mode=ControlMode.CAN), commands=received(Stamped(idle, now))
        )

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
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), commands=received(movement))),
        (0.15, ControlInputs(rc=can_mode, commands=received(movement))),
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
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), commands=received(stop))),
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
            ControlInputs(
                rc=rc_at(0.02, mode=ControlMode.CAN), commands=received(movement, lights)
            ),
        ),
    ]
    assert run(can_steps)[-1].lights.low_beam
    assert run(can_steps)[-1].lights.turn_left  # blink phase is on at t = 0.02 s
    rc_steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), commands=received(lights))),
    ]
    assert not run(rc_steps)[-1].lights.low_beam


@pytest.mark.parametrize(("lights_timeout_s", "low_beam"), [(0.1, False), (0.4, True)])
def test_each_can_command_is_judged_against_its_own_timeout(
    lights_timeout_s: float, low_beam: bool
) -> None:
    """LightsCommand sent once, MovementCommand every step: 0.28 s later the lamps follow the
    old LightsCommand only if its own timeout (not the movement's) allows it."""
    lights = Stamped(LightsCommand(False, False, False, low_beam=True, counter=0), 0.02)
    movement = MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, counter=1)

    def can(now: float) -> ControlInputs:
        return ControlInputs(
            rc=rc_at(now, mode=ControlMode.CAN), commands=received(Stamped(movement, now), lights)
        )

    steps = [*armed_rc(0.0, mode=ControlMode.RC), *held(0.02, 0.3, can)]
    timeouts_s = tuple(
        (kind, lights_timeout_s if kind is LightsCommand else timeout_s)
        for kind, timeout_s in CONFIG.command_timeouts_s
    )
    config = replace(CONFIG, command_timeouts_s=timeouts_s)
    last = run(steps, config)[-1]
    assert last.mode is ControlMode.CAN
    assert last.lights.low_beam is low_beam


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
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), commands=received(sent))),
        (
            0.02 + age_s,
            ControlInputs(rc=rc_at(0.02 + age_s, mode=ControlMode.CAN), commands=received(sent)),
        ),
    ]
    assert run(steps)[-1].mode is mode


# Tests added after mutation testing (docs/mutation.md). The decision's wiring, pinned where
# mutation testing found it untested: sensors reach the monitors and the steering, configuration
# reaches every stage, re-enable and flags are exact.


CAN_IDLE = MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, counter=1)


def test_low_brake_pressure_while_stopped_raises_the_hydro_fault_after_the_response_time() -> None:
    # In STOP the hydraulic brake is at full duty, so a sensor reading 0 bar is a failed brake.
    times = [0.0, 0.1, 0.2, 0.29, 0.31]
    steps = [(now, ControlInputs(hydrobrake_pressure_bar=0.0, rc=rc_at(now))) for now in times]
    outputs = run(steps)
    assert not outputs[3].error_flags & ErrorFlag.HYDRO_PRESSURE_FAULT  # 0.29 s: not 0.3 s yet
    assert outputs[4].error_flags & ErrorFlag.HYDRO_PRESSURE_FAULT
    assert outputs[4].lights.error_led


def test_full_brake_pressure_while_stopped_raises_no_fault() -> None:
    times = [0.0, 0.1, 0.2, 0.29, 0.31, 0.5]
    steps = [(now, ControlInputs(hydrobrake_pressure_bar=5.0, rc=rc_at(now))) for now in times]
    assert all(not out.error_flags & ErrorFlag.HYDRO_PRESSURE_FAULT for out in run(steps))


def test_an_invalid_steering_encoder_reading_stops_rc_driving_with_a_hardware_latch() -> None:
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), steering_measured_norm=math.nan)),
    ]
    outputs = run(steps)
    assert outputs[1].mode is ControlMode.RC
    last = outputs[-1]
    assert last.mode is ControlMode.STOP
    assert last.causes == {Cause.STEERING_ENCODER}
    assert last.error_flags & ErrorFlag.STEERING_ENCODER_FAULT


def test_a_monitor_flag_left_out_of_stop_flags_is_reported_but_does_not_stop() -> None:
    config = replace(CONFIG, monitors=MonitorConfig(stop_flags=ErrorFlag(0)))
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.RC), steering_measured_norm=math.nan)),
    ]
    last = run(steps, config)[-1]
    assert last.mode is ControlMode.RC
    assert not last.causes
    assert last.error_flags & ErrorFlag.STEERING_ENCODER_FAULT


def test_the_boost_works_from_the_encoder_reading_when_one_is_fitted() -> None:
    # Set-point centre, servo measured at +0.5: gain 1 asks for -0.5, i.e. 1.25 ms.
    config = replace(CONFIG, steering=SteeringConfig(boost_gain=1.0))
    (outputs,) = run([(0.0, ControlInputs(steering_measured_norm=0.5))], config)
    assert outputs.steering_pulse_s == pytest.approx(0.00125)


def test_the_hydrobrake_threshold_comes_from_the_configuration() -> None:
    config = replace(CONFIG, hydrobrake_threshold_norm=0.25)
    last = run(armed_rc(0.0, mode=ControlMode.RC, brake_norm=0.75), config)[-1]
    assert last.mode is ControlMode.RC
    assert last.hydrobrake_duty == pytest.approx((0.75 - 0.25) / (1.0 - 0.25))


def test_the_blink_rate_comes_from_the_configuration() -> None:
    # At t = 0.5 s a 1.5 Hz blink is in its dark half (phase 0.75), a 0.5 Hz one in its lit half.
    steps = armed_rc(0.49, mode=ControlMode.RC, hazard=True)
    assert not run(steps)[-1].lights.turn_left
    assert run(steps, replace(CONFIG, blink_rate_hz=0.5))[-1].lights.turn_left


DRIVING_FORWARD: RcChanges = {
    "mode": ControlMode.RC,
    "gear": Gear.FORWARD,
    "throttle_norm": 0.5,
}


def test_a_direction_change_while_driving_is_reported_as_held() -> None:
    forward = [
        (0.02 + 0.01 * tick, ControlInputs(rc=rc_at(0.02 + 0.01 * tick, **DRIVING_FORWARD)))
        for tick in range(5)
    ]
    to_reverse: RcChanges = {**DRIVING_FORWARD, "gear": Gear.REVERSE}
    reverse_now = (0.07, ControlInputs(rc=rc_at(0.07, **to_reverse)))
    outputs = run([*armed_rc(0.0, mode=ControlMode.RC), *forward, reverse_now])
    assert outputs[-2].drive.throttle_volts > 0.0
    assert outputs[-2].direction_change_held is False
    last = outputs[-1]
    assert last.direction_change_held is True
    assert last.drive.forward
    assert last.drive.throttle_volts == 0.0


def test_a_can_re_enable_edge_clears_a_can_timeout_latch() -> None:
    sent = Stamped(CAN_IDLE, 0.02)
    again = Stamped(replace(CAN_IDLE, counter=2), 0.30)
    no_request = Stamped(ControlCommand(remote_stop=False, re_enable=False, counter=0), 0.29)
    re_enable = Stamped(ControlCommand(remote_stop=False, re_enable=True, counter=1), 0.30)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, ControlInputs(rc=rc_at(0.02, mode=ControlMode.CAN), commands=received(sent))),
        (0.25, ControlInputs(rc=rc_at(0.25, mode=ControlMode.CAN), commands=received(sent))),
        (
            0.29,
            ControlInputs(
                rc=rc_at(0.29, mode=ControlMode.CAN), commands=received(again, no_request)
            ),
        ),
        (
            0.30,
            ControlInputs(
                rc=rc_at(0.30, mode=ControlMode.CAN), commands=received(again, re_enable)
            ),
        ),
    ]
    outputs = run(steps)
    assert outputs[2].mode is ControlMode.CAN
    assert outputs[3].causes == {Cause.CAN_LOST}
    assert outputs[4].causes == {Cause.CAN_LOST}  # fresh commands alone do not clear it
    assert outputs[5].mode is ControlMode.CAN
    assert not outputs[5].causes


def test_remote_stop_is_flagged_alongside_an_rc_timeout() -> None:
    stop = Stamped(ControlCommand(remote_stop=True, re_enable=False, counter=0), 0.0)
    (outputs,) = run([(0.0, ControlInputs(commands=received(stop)))])
    assert outputs.error_flags & ErrorFlag.REMOTE_STOP
    assert outputs.error_flags & ErrorFlag.RC_TIMEOUT


def test_no_can_command_timeout_is_flagged_while_rc_drives_without_can() -> None:
    last = run(armed_rc(0.0, mode=ControlMode.RC))[-1]
    assert last.mode is ControlMode.RC
    assert last.error_flags == 0


def test_rc_light_switches_are_ignored_in_can_mode() -> None:
    can_mode: RcChanges = {"mode": ControlMode.CAN, "low_beam": True, "hazard": True}
    steps = [
        (0.0, ControlInputs(rc=rc_at(0.0))),
        (
            0.01,
            ControlInputs(rc=rc_at(0.01, **can_mode), commands=received(Stamped(CAN_IDLE, 0.01))),
        ),
    ]
    last = run(steps)[-1]
    assert last.mode is ControlMode.CAN
    assert not last.lights.low_beam
    assert not last.lights.turn_left  # t = 0.01 s is in the lit half of a blink


# --- when an arriving frame can change the decision (changes_decision) ---------------------------

COUNTED = ControlConfig(supervisor=SupervisorConfig(debounce_frames=3))


def _last_decision(
    steps: list[tuple[float, ControlInputs]], config: ControlConfig = CONFIG
) -> tuple[ControlState, ControlInputs, float]:
    """The state the last of `steps` left, the inputs it was taken on and its instant."""
    state = ControlState()
    for now, inputs in framed(steps):
        state, _ = controller_step(state, inputs, now, config)
    return state, inputs, now


def _rc_driving() -> tuple[ControlState, ControlInputs, float]:
    """Armed on RC at 10 ms, a CAN movement command and a lights command seen fresh."""
    movement, lights = Stamped(CAN_IDLE, 0.005), Stamped(LIGHTS_OFF, 0.005)
    steps = armed_rc(0.0, mode=ControlMode.RC)
    steps[-1] = (
        0.01,
        replace(steps[-1][1], commands=steps[-1][1].commands.with_frames(movement, lights)),
    )
    return _last_decision(steps)


def test_a_frame_that_repeats_a_request_with_a_new_counter_does_not_change_the_decision() -> None:
    state, seen, decided_at = _rc_driving()
    assert state.supervisor.mode is ControlMode.RC
    assert not changes_decision(state, seen, decided_at, seen, CONFIG)  # nothing arrived
    movement = seen.commands.get(MovementCommand)
    assert movement is not None
    assert seen.rc is not None
    repeats = replace(
        seen,
        rc=Stamped(seen.rc.value, 0.017),
        rc_frames=seen.rc_frames + 2,
        commands=seen.commands.with_frames(
            Stamped(replace(movement.value, counter=9), 0.015),
            Stamped(replace(LIGHTS_OFF, counter=3), 0.015),
        ),
    )
    assert not changes_decision(state, seen, decided_at, repeats, CONFIG)


@pytest.mark.parametrize(
    "news",
    [
        {"rc": rc_at(0.015, mode=ControlMode.RC, throttle_norm=0.2)},
        {"rc": rc_at(0.015, mode=ControlMode.STOP)},
        {"rc": Stamped(None, 0.015)},  # an implausible frame
        {"movement": Stamped(replace(CAN_IDLE, throttle_norm=0.2, counter=2), 0.015)},
        {"lights": Stamped(replace(LIGHTS_OFF, hazard=True, counter=1), 0.015)},
        {"control": Stamped(ControlCommand(remote_stop=True, re_enable=False, counter=0), 0.015)},
        {"control_edges": CommandEdges(re_enable=True, remote_stop=False)},
    ],
    ids=[
        "rc-throttle",
        "rc-stop",
        "rc-implausible",
        "can-throttle",
        "hazard",
        "first-control",
        "edge",
    ],
)
def test_a_frame_that_asks_for_something_new_changes_the_decision(news: dict[str, Any]) -> None:
    state, seen, decided_at = _rc_driving()
    frames = [news.pop(slot) for slot in ("movement", "lights", "control") if slot in news]
    arrivals = replace(
        seen,
        **news,
        rc_frames=seen.rc_frames + ("rc" in news),
        commands=seen.commands.with_frames(*frames),
    )
    assert changes_decision(state, seen, decided_at, arrivals, CONFIG)


def test_a_repeat_of_a_request_the_decision_saw_stale_changes_it() -> None:
    """A source coming back after its timeout: the decision must see it fresh at once."""
    state, seen, _ = _rc_driving()
    movement = seen.commands.get(MovementCommand)
    assert movement is not None
    back = Stamped(replace(movement.value, counter=5), 0.2)
    arrivals = replace(seen, commands=seen.commands.with_frames(back))
    assert changes_decision(state, seen, 0.19, arrivals, CONFIG)  # seen at 5 ms: stale at 190
    assert not changes_decision(state, seen, 0.01, arrivals, CONFIG)


def test_while_the_switch_debounce_counts_every_rc_frame_changes_the_decision() -> None:
    def frames(*modes: ControlMode) -> list[tuple[float, ControlInputs]]:
        return [
            (0.007 * n, ControlInputs(rc=rc_at(0.007 * n, mode=mode)))
            for n, mode in enumerate(modes)
        ]

    stop, rc = [ControlMode.STOP] * 3, ControlMode.RC
    state, seen, decided_at = _last_decision(frames(*stop, rc), COUNTED)
    assert (state.supervisor.candidate, state.supervisor.run_frames) == (rc, 1)  # one of three
    assert seen.rc is not None
    repeat = replace(seen, rc=Stamped(seen.rc.value, 0.03), rc_frames=seen.rc_frames + 1)
    assert changes_decision(state, seen, decided_at, repeat, COUNTED)
    settled, seen, decided_at = _last_decision(frames(*stop, rc, rc, rc), COUNTED)
    assert settled.supervisor.mode is rc
    assert seen.rc is not None
    repeat = replace(seen, rc=Stamped(seen.rc.value, 0.045), rc_frames=seen.rc_frames + 1)
    assert not changes_decision(settled, seen, decided_at, repeat, COUNTED)


MODE_LIST = [ControlMode.STOP, ControlMode.RC, ControlMode.CAN]
MODES = st.sampled_from(MODE_LIST)
RARELY = st.sampled_from([False, False, False, False, True])


def _arming(mode: ControlMode) -> list[tuple[float, ControlInputs]]:
    """The switch held at STOP, then at `mode`, three frames each, throttle idle, CAN fresh."""
    movement = Stamped(CAN_IDLE, 0.0)
    return [
        (0.007 * n, ControlInputs(rc=rc_at(0.007 * n, mode=position), commands=received(movement)))
        for n, position in enumerate([ControlMode.STOP] * 3 + [mode] * 3)
    ]


@st.composite
def histories(draw: st.DrawFn) -> list[tuple[float, ControlInputs]]:
    """Armed on RC or CAN (or left at STOP), then up to ten decisions on RC frames (any switch
    position, throttle idle or open, now and then implausible), CAN movement and control
    commands, each new or not, mostly a frame period apart, sometimes past a timeout."""
    armed = draw(MODES)
    positions = st.sampled_from([armed, armed, armed, *MODE_LIST])  # mostly held
    steps = _arming(armed)
    now = steps[-1][0]
    for _ in range(draw(st.integers(0, 10))):
        now += draw(st.sampled_from([*[0.003, 0.007, 0.007, 0.010] * 3, 0.150]))
        frame = st.builds(
            lambda mode, throttle, at=now: rc_at(at, mode=mode, throttle_norm=throttle),
            positions,
            st.sampled_from([0.0, 0.0, 0.5]),
        )
        implausible = st.just(Stamped(None, now))
        rc = draw(st.one_of(st.none(), st.none(), frame, frame, frame, frame, frame, implausible))
        movement = draw(
            st.one_of(
                st.none(),
                st.builds(
                    lambda throttle, counter, at=now: Stamped(
                        replace(CAN_IDLE, throttle_norm=throttle, counter=counter), at
                    ),
                    st.sampled_from([0.0, 0.5]),
                    st.integers(0, 15),
                ),
            )
        )
        control = draw(
            st.one_of(
                st.none(),
                st.builds(
                    lambda stop, again, at=now: Stamped(ControlCommand(stop, again, 0), at),
                    RARELY,
                    RARELY,
                ),
            )
        )
        previous = steps[-1][1]
        steps.append(
            (
                now,
                ControlInputs(
                    rc=rc or previous.rc,
                    commands=previous.commands.with_frames(movement, control),
                ),
            )
        )
    return steps


@settings(max_examples=300)
@given(
    histories(),
    st.sampled_from([0.0005, 0.003, 0.009]),
    st.integers(0, 3),
    st.integers(0, 15),
    st.booleans(),
)
def test_a_decision_cannot_tell_frames_that_repeat_a_request_from_the_ones_it_saw(
    steps: list[tuple[float, ControlInputs]],
    later_s: float,
    rc_repeats: int,
    counter: int,
    control_repeats: bool,
) -> None:
    """What `changes_decision` passes over, the decision ignores: at the next decision, frames
    judged repeats (new counters, any number of them) give the outputs that the frames the last
    decision saw give, stamped alike. Their age is all that differs, and only time acts on it."""
    state, seen, decided_at = _last_decision(steps, COUNTED)
    now = decided_at + later_s
    at = decided_at + later_s / 2

    def restamped(slot: Stamped[T] | None) -> Stamped[T] | None:
        return None if slot is None else Stamped(slot.value, at)

    edges = seen.control_edges
    seen_control = control = seen.commands.get(ControlCommand)
    if control_repeats and seen_control is not None:
        control = Stamped(
            replace(seen_control.value, counter=(seen_control.value.counter + 1) % 16), at
        )
        edges = command_edges(seen_control.value, control.value)
    seen_movement = movement = seen.commands.get(MovementCommand)
    if movement is not None:
        movement = Stamped(replace(movement.value, counter=counter), at)
    arrivals = replace(
        seen,
        rc=restamped(seen.rc) if rc_repeats else seen.rc,
        rc_frames=seen.rc_frames + rc_repeats,
        commands=seen.commands.with_frames(movement, control),
        control_edges=edges,
        control_frames=seen.control_frames + (control is not seen_control),
    )
    assume(not changes_decision(state, seen, decided_at, arrivals, COUNTED))
    event(f"{state.supervisor.mode.name} rc+{rc_repeats} ctl{control is not seen_control}")
    as_seen = replace(
        seen,
        rc=restamped(seen.rc) if rc_repeats else seen.rc,
        commands=seen.commands.with_frames(
            restamped(seen_movement),
            restamped(seen_control) if control is not seen_control else seen_control,
        ),
    )
    after_repeats, outputs = controller_step(state, arrivals, now, COUNTED)
    after_seen, expected = controller_step(state, as_seen, now, COUNTED)
    assert outputs == expected
    assert replace(after_repeats, rc_frames_seen=0, control_frames_seen=0) == replace(
        after_seen, rc_frames_seen=0, control_frames_seen=0
    )


# --- the command table's rules --------------------------------------------------------------------


def test_each_of_the_decisions_own_rules_is_its_own_messages_row_alone() -> None:
    """A row that names a rule of the decision for another message, or a second row of one,
    would be ignored: the table is refused when the controller is imported."""
    check_rules(COMMANDS)
    control, movement, lights = (command_row(kind) for kind in RULES.values())
    stray = replace(lights, use=Use.SET_POINTS)
    with pytest.raises(TypeError, match="SET_POINTS is MovementCommand's rule, not Movement"):
        check_rules((control, movement, stray))
    with pytest.raises(TypeError, match="LIGHT_REQUESTS is LightsCommand's rule, not no row's"):
        check_rules((control, movement))


GOVERNED = replace(CONFIG, governor=GovernorConfig(2.5, 0.462))


def _driving(mode: ControlMode, throttle: float, speed_mps: float | None) -> ControlInputs:
    """RC or CAN asking for `throttle` forward, at a wheel speed of `speed_mps`."""
    if mode is ControlMode.RC:
        return ControlInputs(rc=rc_at(0.0, mode=mode, throttle_norm=throttle), speed_mps=speed_mps)
    movement = MovementCommand(0.0, throttle, 0.0, Gear.FORWARD, counter=3)
    commands = received(Stamped(movement, 0.0))
    return ControlInputs(rc=rc_at(0.0, mode=mode), commands=commands, speed_mps=speed_mps)


def _restamped(inputs: ControlInputs, now: float) -> ControlInputs:
    rc = None if inputs.rc is None else replace(inputs.rc, received_at=now)
    slot = inputs.commands.get(MovementCommand)
    commands = inputs.commands if slot is None else received(replace(slot, received_at=now))
    return replace(inputs, rc=rc, commands=commands)


def governed_run(
    mode: ControlMode, speed_mps: float | None, config: ControlConfig = GOVERNED
) -> ControlOutputs:
    """Armed by RC, handed to `mode` at zero throttle, then full throttle for 2 s at a steady
    wheel speed."""
    idle, full = _driving(mode, 0.0, speed_mps), _driving(mode, 1.0, speed_mps)
    steps = [
        *armed_rc(0.0, mode=ControlMode.RC),
        (0.02, _restamped(idle, 0.02)),
        *held(0.03, 2.0, lambda now: _restamped(full, now)),
    ]
    return run(steps, config)[-1]


@pytest.mark.parametrize("mode", [ControlMode.RC, ControlMode.CAN])
@pytest.mark.parametrize(
    ("speed", "volts", "duty"),
    [
        (1.0, 5.0, 0.0),  # well below the limit: the throttle asked, all of it
        (2.25, 2.5, 0.0),  # half way through the band: half the throttle
        (2.7, 0.0, 0.0),  # past the limit within the margin: no throttle, no brake
        (2.9, 0.0, 0.2),  # brake 0.6: regeneration and a graded hydraulic duty
        (3.0, 0.0, 1.0),  # past it by twice the margin: full brake (hydraulic at full duty)
    ],
)
def test_the_speed_limit_governs_rc_and_can_alike(
    mode: ControlMode, speed: float, volts: float, duty: float
) -> None:
    last = governed_run(mode, speed)
    assert last.mode is mode  # governed, never stopped
    assert last.drive.enable
    assert not last.ebrake_engaged
    assert last.drive.throttle_volts == pytest.approx(volts)
    assert last.hydrobrake_duty == pytest.approx(duty)
    assert last.speed_limited is (speed > 2.0)
    assert last.lights.brake is (duty > 0.0)


def test_without_a_trusted_speed_the_throttle_stops_at_the_ceiling() -> None:
    last = governed_run(ControlMode.RC, None)
    assert last.drive.throttle_volts == pytest.approx(0.462 * 5.0)
    assert last.speed_limited
    unlimited = governed_run(ControlMode.RC, None, CONFIG)
    assert unlimited.drive.throttle_volts == pytest.approx(5.0)
    assert not unlimited.speed_limited
