"""Feedback monitors: hydraulic pressure and steering encoder against the command."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.sensor_checks import (
    MonitorConfig,
    MonitorInputs,
    MonitorState,
    monitor_step,
    stop_required,
)
from bywire.control.steering import step_towards
from bywire.error_flags import ErrorFlag

CONFIG = MonitorConfig()
HYDRO = ErrorFlag.HYDRO_PRESSURE_FAULT
ENCODER = ErrorFlag.STEERING_ENCODER_FAULT
NONE = ErrorFlag(0)
NAN, INF = math.nan, math.inf
# Numbers exact in binary, so boundary times are exact: 0.75 / 2 + 0.25 = 0.625 s to detection.
EXACT = MonitorConfig(
    steering_tolerance_norm=0.25, servo_speed_norm_per_s=2.0, steering_margin_s=0.25
)


def _run(
    steps: Sequence[tuple[float, MonitorInputs]], config: MonitorConfig = CONFIG
) -> list[ErrorFlag]:
    state, flags = MonitorState(), []
    for now, inputs in steps:
        state, raised = monitor_step(state, inputs, now, config)
        flags.append(raised)
    return flags


def _braking(duty: float, pressure_bar: float | None) -> MonitorInputs:
    return MonitorInputs(hydro_duty=duty, pressure_bar=pressure_bar)


def _steering(command_norm: float, measured_norm: float | None) -> MonitorInputs:
    return MonitorInputs(steering_command_norm=command_norm, steering_measured_norm=measured_norm)


# --- hydraulic pressure -----------------------------------------------------------------------


@pytest.mark.parametrize(("now", "flags"), [(0.3, NONE), (0.3001, HYDRO), (5.0, HYDRO)])
def test_pressure_fault_only_after_the_response_time(now: float, flags: ErrorFlag) -> None:
    assert _run([(0.0, _braking(1.0, 0.0)), (now, _braking(1.0, 0.0))])[-1] == flags


@pytest.mark.parametrize(
    ("duty", "pressure_bar", "flags"),
    [
        (1.0, 5.0, NONE),  # exactly the expected minimum
        (1.0, 4.99, HYDRO),
        (0.5, 2.5, NONE),  # the expected minimum scales with the duty
        (0.5, 2.49, HYDRO),
        (0.2, 0.99, HYDRO),  # exactly the lowest checked duty
        (0.1999, 0.0, NONE),  # below it: no pressure expected
        (0.0, 0.0, NONE),
        (1.0, NAN, HYDRO),
        (1.0, INF, HYDRO),
        (1.0, -INF, HYDRO),
        (1.0, None, NONE),  # no sensor, no check
    ],
)
def test_pressure_table(duty: float, pressure_bar: float | None, flags: ErrorFlag) -> None:
    assert (
        _run([(0.0, _braking(duty, pressure_bar)), (1.0, _braking(duty, pressure_bar))])[-1]
        == flags
    )


def test_pressure_may_build_within_the_response_time() -> None:
    pressures = [(0.0, 0.0), (0.1, 1.0), (0.25, 4.0), (0.3, 5.5), (1.0, 5.5)]
    assert _run([(now, _braking(1.0, bar)) for now, bar in pressures]) == [NONE] * 5


def test_pressure_fault_clears_when_pressure_follows_and_rearms() -> None:
    steps = [(0.0, 0.0), (0.5, 0.0), (0.6, 6.0), (0.7, 0.0), (0.9, 0.0), (1.1, 0.0)]
    flags = _run([(now, _braking(1.0, bar)) for now, bar in steps])
    assert flags == [NONE, HYDRO, NONE, NONE, NONE, HYDRO]


def test_pressure_fault_clears_when_the_duty_drops() -> None:
    steps = [(0.0, _braking(1.0, 0.0)), (0.5, _braking(1.0, 0.0)), (0.6, _braking(0.0, 0.0))]
    assert _run(steps) == [NONE, HYDRO, NONE]


def test_pressure_scale_is_configurable() -> None:
    config = MonitorConfig(hydro_bar_at_full_duty=20.0, hydro_min_duty=0.5, hydro_response_s=0.1)
    steps = [(0.0, _braking(1.0, 10.0)), (0.2, _braking(1.0, 10.0)), (0.3, _braking(0.4, 0.0))]
    assert _run(steps, config) == [NONE, HYDRO, NONE]


# --- steering encoder -------------------------------------------------------------------------


@pytest.mark.parametrize("measured_norm", [NAN, INF, -INF, 1.2001, -1.2001])
def test_invalid_encoder_reading_faults_at_once(measured_norm: float) -> None:
    assert _run([(0.0, _steering(0.0, measured_norm))]) == [ENCODER]


@pytest.mark.parametrize("measured_norm", [1.2, -1.2])
def test_encoder_limit_is_inclusive(measured_norm: float) -> None:
    assert _run([(0.0, _steering(measured_norm, measured_norm))]) == [NONE]


def test_encoder_fault_clears_when_the_reading_is_valid_again() -> None:
    steps = [(0.0, _steering(0.0, NAN)), (0.01, _steering(0.0, 0.0))]
    assert _run(steps) == [ENCODER, NONE]


@pytest.mark.parametrize(("measured_norm", "flags"), [(0.0, NONE), (-0.0001, ENCODER)])
def test_steering_tolerance_is_inclusive(measured_norm: float, flags: ErrorFlag) -> None:
    """0.15 − 0.0 is exactly the default tolerance."""
    steps = [(now, _steering(0.15, measured_norm)) for now in (0.0, 0.5, 1.0, 5.0)]
    assert _run(steps)[-1] == flags


@pytest.mark.parametrize(("now", "flags"), [(0.5, NONE), (0.625, NONE), (0.6251, ENCODER)])
def test_stuck_servo_faults_after_travel_time_plus_margin(now: float, flags: ErrorFlag) -> None:
    """A servo turning at 2 /s would be within 0.25 of 1.0 after 0.375 s; the margin is 0.25 s."""
    ticks = [0.0, 0.125, 0.25, 0.375, now]
    assert _run([(t, _steering(1.0, 0.0)) for t in ticks], EXACT)[-1] == flags


def test_stuck_servo_with_defaults_faults_within_a_second() -> None:
    """0.85 / 1.5 + 0.2 ≈ 0.77 s with the defaults, checked every 10 ms."""
    flags = _run([(tick * 0.01, _steering(1.0, 0.0)) for tick in range(100)])
    first = flags.index(ENCODER) * 0.01
    assert 0.76 <= first <= 0.78


def test_encoder_fault_clears_when_the_servo_arrives() -> None:
    steps = [(t, _steering(1.0, 0.0)) for t in (0.0, 0.125, 0.25, 0.375, 0.75)]
    flags = _run([*steps, (0.8, _steering(1.0, 0.8))], EXACT)
    assert flags[-2:] == [ENCODER, NONE]


def test_servo_moving_the_wrong_way_faults() -> None:
    steps = [(tick * 0.125, _steering(1.0, max(-0.2 * tick, -1.0))) for tick in range(7)]
    assert _run(steps, EXACT)[-1] == ENCODER


@pytest.mark.parametrize(
    ("command_norm", "measured_norm"), [(1.5, 1.0), (-1.3, -1.0), (-INF, -1.0), (NAN, 0.0)]
)
def test_command_counts_as_the_servo_gets_it(command_norm: float, measured_norm: float) -> None:
    """Out of range clamps and NaN centres, as in pulse_for_steering."""
    steps = [(tick * 0.1, _steering(command_norm, measured_norm)) for tick in range(20)]
    assert _run(steps) == [NONE] * 20


def test_fast_servo_reversing_leaves_the_model_behind_it() -> None:
    """A servo at twice the modelled speed overshoots the model towards the old command; when the
    command turns back, the model must start from the servo, not from where it lagged."""
    no_margin = replace(EXACT, steering_margin_s=0.0)
    steps = [
        (0.0, _steering(-1.0, 0.0)),
        (0.125, _steering(0.0, -0.5)),
        (0.15625, _steering(0.0, -0.375)),
    ]
    assert _run(steps, no_margin) == [NONE] * 3


def test_slow_servo_within_margin_does_not_fault() -> None:
    """Half the modelled speed, but only 0.5 to go: it arrives 0.125 s late, inside the margin."""
    steps = [(tick * 0.125, _steering(0.5, min(0.125 * tick, 0.5))) for tick in range(10)]
    assert _run(steps, EXACT) == [NONE] * 10


# --- STOP policy and configuration ------------------------------------------------------------


@pytest.mark.parametrize(
    ("flags", "config", "stop"),
    [
        (HYDRO, CONFIG, True),
        (ENCODER, CONFIG, True),
        (NONE, CONFIG, False),
        (ErrorFlag.RC_TIMEOUT, CONFIG, False),
        (HYDRO, MonitorConfig(stop_flags=ENCODER), False),
        (HYDRO | ENCODER, MonitorConfig(stop_flags=ENCODER), True),
    ],
)
def test_stop_required_follows_the_configuration(
    flags: ErrorFlag, config: MonitorConfig, stop: bool
) -> None:
    assert stop_required(flags, config) is stop


def test_stop_required_defaults_to_both_flags() -> None:
    assert stop_required(int(HYDRO))
    assert stop_required(int(ENCODER))


@pytest.mark.parametrize(
    "make",
    [
        lambda: MonitorConfig(hydro_min_duty=-0.1),
        lambda: MonitorConfig(hydro_response_s=NAN),
        lambda: MonitorConfig(steering_margin_s=INF),
        lambda: MonitorConfig(servo_speed_norm_per_s=0.0),
    ],
)
def test_config_rejects_nonsense(make: Callable[[], MonitorConfig]) -> None:
    with pytest.raises(ValueError, match="must be finite"):
        make()


# --- properties -------------------------------------------------------------------------------

DT = st.one_of(st.sampled_from([0.0, 0.01, 0.02, 0.1]), st.floats(0.0, 1.0))
COMMAND = st.floats(-1.0, 1.0)
DUTY = st.one_of(st.just(1.0), st.floats(0.0, 1.0), st.just(math.nan))
ANY = st.floats()


@given(st.lists(st.tuples(DT, COMMAND, DUTY), max_size=80))
def test_measurement_equal_to_command_never_raises(steps: list[tuple[float, float, float]]) -> None:
    now, state = 0.0, MonitorState()
    for dt, command_norm, duty in steps:
        now += dt
        inputs = MonitorInputs(
            duty, CONFIG.hydro_bar_at_full_duty * duty, command_norm, command_norm
        )
        state, flags = monitor_step(state, inputs, now, CONFIG)
        assert flags == NONE


@given(st.lists(st.tuples(DT, ANY, ANY), max_size=80))
def test_missing_sensors_never_raise(steps: list[tuple[float, float, float]]) -> None:
    now, state = 0.0, MonitorState()
    for dt, command_norm, duty in steps:
        now += dt
        state, flags = monitor_step(state, MonitorInputs(duty, None, command_norm), now, CONFIG)
        assert flags == NONE


TIGHT = [CONFIG, replace(CONFIG, steering_margin_s=0.0), replace(EXACT, steering_margin_s=0.0)]


@given(
    st.lists(st.tuples(DT, COMMAND), max_size=80),
    st.floats(1.0, 3.0),
    st.booleans(),
    st.sampled_from(TIGHT),
)
def test_servo_at_least_as_fast_as_modelled_never_raises(
    steps: list[tuple[float, float]],
    speed_factor: float,
    follows_new_command: bool,
    config: MonitorConfig,
) -> None:
    """A servo turning at ≥ the modelled speed, towards the last or the new command, is fine.

    Even with no margin at all: the model never gets ahead of such a servo.
    """
    speed = config.servo_speed_norm_per_s * speed_factor
    now, target, position, state = 0.0, 0.0, 0.0, MonitorState()
    for dt, command_norm in steps:
        now += dt
        target = command_norm if follows_new_command else target
        position = step_towards(position, target, speed * dt)
        state, flags = monitor_step(state, _steering(command_norm, position), now, config)
        target = command_norm
        assert flags == NONE


# Tests added after mutation testing (docs/mutation.md). Monitors at their exact edges:
# configuration messages, the slow-servo model's "strictly ahead" rule on ties, and both faults
# raised together.


def test_a_slow_servo_speed_below_one_per_second_is_a_valid_setting() -> None:
    assert MonitorConfig(servo_speed_norm_per_s=0.5).servo_speed_norm_per_s == 0.5


def test_a_negative_threshold_is_refused_with_a_message_saying_what_is_wrong() -> None:
    with pytest.raises(ValueError, match=r"^monitor thresholds must be finite and >= 0$"):
        MonitorConfig(steering_margin_s=-1.0)


def test_a_bad_servo_speed_is_refused_with_a_message_naming_it() -> None:
    with pytest.raises(ValueError, match=r"^servo_speed_norm_per_s must be finite and > 0$"):
        MonitorConfig(servo_speed_norm_per_s=0.0)


def _model_after(model: float, target: float, command: float, measured: float) -> float | None:
    """Where the servo model stands after one step taking no time (so only the pull counts)."""
    state = MonitorState(servo_model_norm=model, servo_target_norm=target, updated_at=1.0)
    inputs = MonitorInputs(steering_command_norm=command, steering_measured_norm=measured)
    new_state, _ = monitor_step(state, inputs, 1.0, CONFIG)
    return new_state.servo_model_norm


def test_a_reading_strictly_closer_to_the_new_command_pulls_the_model_to_it() -> None:
    # last target 0, model still there; the command is now 0.5 and the servo is already at 0.25
    assert _model_after(model=0.0, target=0.0, command=0.5, measured=0.25) == 0.25


def test_a_reading_only_as_close_to_the_new_command_as_the_model_does_not_pull_it() -> None:
    # model at the last target 0.5; the command is 0.25; the reading 0.0 is 0.25 away as well
    assert _model_after(model=0.5, target=0.5, command=0.25, measured=0.0) == 0.5


def test_a_reading_only_as_close_to_the_last_target_as_the_model_does_not_pull_it() -> None:
    # last target 0.5, model short of it at 0.25, the reading 0.75 as far beyond it
    assert _model_after(model=0.25, target=0.5, command=0.25, measured=0.75) == 0.25


def test_a_servo_stuck_beyond_its_target_is_late_once_the_model_is_within_tolerance() -> None:
    state = MonitorState(servo_model_norm=0.25, servo_target_norm=0.5, updated_at=1.0)
    stuck = MonitorInputs(steering_command_norm=0.25, steering_measured_norm=0.75)
    state, first = monitor_step(state, stuck, 1.0, CONFIG)
    assert state.steering_late_since == 1.0
    _, later = monitor_step(state, stuck, 1.25, CONFIG)
    assert first == ErrorFlag(0)
    assert later == ErrorFlag.STEERING_ENCODER_FAULT


def test_a_pressure_fault_and_an_encoder_fault_are_raised_together() -> None:
    broken = MonitorInputs(hydro_duty=1.0, pressure_bar=0.0, steering_measured_norm=math.nan)
    state, _ = monitor_step(MonitorState(), broken, 0.0, CONFIG)
    _, flags = monitor_step(state, broken, 1.0, CONFIG)
    assert flags == ErrorFlag.HYDRO_PRESSURE_FAULT | ErrorFlag.STEERING_ENCODER_FAULT
