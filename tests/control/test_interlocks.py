"""Interlocks: clamps, brake over throttle, direction change at standstill, throttle slew."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.interlocks import (
    InterlockConfig,
    InterlockState,
    can_throttle_allowed,
    interlock_step,
)
from bywire.control.mux import Movement
from bywire.model import ControlMode, Gear

CONFIG = InterlockConfig()
F, R, N = Gear.FORWARD, Gear.REVERSE, Gear.NEUTRAL
NAN, INF = math.nan, math.inf
Step = tuple[float, Movement, float | None]  # (now or dt, requested, measured speed)


def _drive(gear: Gear, throttle_norm: float = 0.0, brake_norm: float = 0.0) -> Movement:
    return Movement(0.0, throttle_norm, brake_norm, gear)


def _state(gear: Gear, throttle_norm: float = 0.0, at: float = 0.0) -> InterlockState:
    """Driving in `gear` with `throttle_norm` applied, last stepped at `at`."""
    return InterlockState(gear=gear, direction=gear, throttle_norm=throttle_norm, updated_at=at)


def _run(state: InterlockState, steps: Sequence[Step]) -> tuple[InterlockState, Movement, bool]:
    applied, held = Movement(), False
    for now, requested, speed_mps in steps:
        state, applied, held = interlock_step(state, requested, speed_mps, now, CONFIG)
    return state, applied, held


# --- clamps in command units -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("throttle_norm", "expected"),
    [(NAN, 0.0), (INF, 0.0), (-INF, 0.0), (-0.5, 0.0), (1.5, 1.0), (0.4, 0.4)],
)
def test_throttle_is_clamped_and_non_finite_is_zero(throttle_norm: float, expected: float) -> None:
    _, applied, _ = interlock_step(_state(F, 1.0), _drive(F, throttle_norm), 0.0, 0.0, CONFIG)
    assert applied.throttle_norm == expected


@pytest.mark.parametrize(
    ("brake_norm", "expected"),
    [(NAN, 1.0), (INF, 1.0), (-INF, 1.0), (-0.5, 0.0), (1.5, 1.0), (0.3, 0.3)],
)
def test_brake_is_clamped_and_non_finite_is_full(brake_norm: float, expected: float) -> None:
    _, applied, _ = interlock_step(_state(F), _drive(F, 0.0, brake_norm), 0.0, 0.0, CONFIG)
    assert applied.brake_norm == expected


@pytest.mark.parametrize(
    ("steering_norm", "expected"),
    [(NAN, 0.3), (INF, 0.3), (-INF, 0.3), (-5.0, -1.0), (5.0, 1.0), (-0.7, -0.7)],
)
def test_steering_is_clamped_and_non_finite_holds(steering_norm: float, expected: float) -> None:
    state = InterlockState(steering_norm=0.3)
    new_state, applied, _ = interlock_step(state, Movement(steering_norm), None, 0.0, CONFIG)
    assert applied.steering_norm == expected
    assert new_state.steering_norm == expected


# --- brake beats throttle, neutral has no drive -----------------------------------------------


@pytest.mark.parametrize(
    ("brake_norm", "expected"), [(0.0, 0.8), (1e-9, 0.0), (0.1, 0.0), (1.0, 0.0), (NAN, 0.0)]
)
def test_any_brake_forces_throttle_to_zero(brake_norm: float, expected: float) -> None:
    requested = _drive(F, 0.8, brake_norm)
    _, applied, _ = interlock_step(_state(F, 0.8), requested, 1.0, 0.0, CONFIG)
    assert applied.throttle_norm == expected


def test_neutral_is_granted_at_once_at_speed_and_has_no_throttle() -> None:
    _, applied, held = interlock_step(_state(F, 0.8), _drive(N, 0.8), 3.0, 0.0, CONFIG)
    assert (applied.gear, applied.throttle_norm, held) == (N, 0.0, False)


# --- direction change only near standstill ----------------------------------------------------


@pytest.mark.parametrize(("applied", "requested"), [(F, R), (R, F)])
def test_reversal_at_speed_is_held_with_throttle_zero(applied: Gear, requested: Gear) -> None:
    _, out, held = interlock_step(_state(applied, 0.5), _drive(requested, 0.5), 1.0, 0.0, CONFIG)
    assert (out.gear, out.throttle_norm, held) == (applied, 0.0, True)


def test_held_reversal_passes_the_brake_through() -> None:
    _, out, _ = interlock_step(_state(F), _drive(R, 0.0, 0.6), 1.0, 0.0, CONFIG)
    assert out.brake_norm == 0.6


@pytest.mark.parametrize(
    ("now", "gear", "held"), [(1.4999, F, True), (1.5, R, False), (1.6, R, False)]
)
def test_reversal_granted_exactly_after_the_dwell(now: float, gear: Gear, held: bool) -> None:
    """Standstill and zero throttle from t = 1.0; the dwell is 0.5 s."""
    state, _, _ = _run(_state(F), [(1.0, _drive(R), 0.0)])
    _, out, was_held = interlock_step(state, _drive(R), 0.0, now, CONFIG)
    assert (out.gear, was_held) == (gear, held)


@pytest.mark.parametrize(
    ("speed_mps", "gear"), [(0.05, R), (-0.05, R), (0.0500001, F), (-0.0500001, F), (INF, F)]
)
def test_standstill_threshold_is_inclusive(speed_mps: float, gear: Gear) -> None:
    steps = [(t, _drive(R), speed_mps) for t in (0.0, 0.25, 0.5)]
    _, out, _ = _run(_state(F), steps)
    assert out.gear is gear


def test_throttle_during_the_dwell_restarts_it() -> None:
    steps = [(0.0, _drive(R), 0.0), (0.3, _drive(R, 0.1), 0.0), (0.6, _drive(R), 0.0)]
    state, out, held = _run(_state(F), steps)
    assert (out.gear, held) == (F, True)
    _, out, held = interlock_step(state, _drive(R), 0.0, 1.1, CONFIG)
    assert (out.gear, held) == (R, False)


def test_moving_during_the_dwell_restarts_it() -> None:
    steps = [(0.0, _drive(R), 0.0), (0.3, _drive(R), 0.2), (0.6, _drive(R), 0.0)]
    _, out, held = _run(_state(F), steps)
    assert (out.gear, held) == (F, True)


def test_reversal_through_neutral_is_still_held() -> None:
    steps = [(0.0, _drive(N), 2.0), (0.1, _drive(R, 0.5), 2.0)]
    state, out, held = _run(_state(F, 0.5), steps)
    assert (out.gear, out.throttle_norm, held) == (N, 0.0, True)
    assert state.direction is F


def test_leaving_neutral_against_the_rolling_direction_is_held() -> None:
    _, out, held = interlock_step(InterlockState(), _drive(F, 0.5), -0.5, 0.0, CONFIG)
    assert (out.gear, held) == (N, True)


@pytest.mark.parametrize("speed_mps", [0.0, 1.0, None])
def test_first_direction_without_history_is_granted(speed_mps: float | None) -> None:
    _, out, held = interlock_step(InterlockState(), _drive(F), speed_mps, 0.0, CONFIG)
    assert (out.gear, held) == (F, False)


@pytest.mark.parametrize("speed_mps", [None, NAN])
@pytest.mark.parametrize(("now", "gear"), [(0.5, F), (1.4999, F), (1.5, R)])
def test_unknown_speed_needs_the_longer_dwell_with_the_brake_on(
    speed_mps: float | None, now: float, gear: Gear
) -> None:
    braking = _drive(R, brake_norm=CONFIG.unknown_speed_brake_norm)
    steps = [(0.0, braking, speed_mps), (now, braking, speed_mps)]
    _, out, _ = _run(_state(F), steps)
    assert out.gear is gear


def test_unknown_speed_and_no_brake_never_settles_a_coasting_robot() -> None:
    """Hazard 10: waiting proves nothing without a speed; a robot may coast for seconds."""
    coasting = _drive(R, brake_norm=CONFIG.unknown_speed_brake_norm - 0.01)
    steps = [(0.0, coasting, None), (10.0, coasting, None)]
    _, out, held = _run(_state(F), steps)
    assert (out.gear, held) == (F, True)


def test_sensor_dropout_falls_back_to_the_longer_dwell() -> None:
    steps = [(0.0, _drive(R), 0.0), (0.3, _drive(R), None), (0.6, _drive(R), 0.0)]
    _, out, _ = _run(_state(F), steps)
    assert out.gear is F


def test_a_measured_speed_overrules_the_quiet_time() -> None:
    steps = [(0.0, _drive(R), None), (1.0, _drive(R), 1.0), (2.0, _drive(R), None)]
    _, out, _ = _run(_state(F), steps)
    assert out.gear is F


def test_the_robot_can_drive_forward_then_reverse_then_forward() -> None:
    steps = [(0.0, _drive(F), 0.0), (0.5, _drive(R), 0.0), (1.0, _drive(R), 0.0)]
    state, out, _ = _run(InterlockState(), steps)
    assert out.gear is R
    _, out, _ = interlock_step(state, _drive(F), 0.0, 1.0, CONFIG)
    assert out.gear is F


# --- throttle slew ----------------------------------------------------------------------------


def test_throttle_rises_at_the_slew_limit_and_reaches_full_in_one_second() -> None:
    state, applied, _ = interlock_step(_state(F), _drive(F, 1.0), 0.0, 0.0, CONFIG)
    ramp = [applied.throttle_norm]
    for tick in range(1, 12):
        state, applied, _ = interlock_step(state, _drive(F, 1.0), 0.0, tick * 0.1, CONFIG)
        ramp.append(applied.throttle_norm)
    assert ramp == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.0])


def test_throttle_falls_at_once() -> None:
    _, applied, _ = interlock_step(_state(F, 0.9), _drive(F, 0.1), 1.0, 0.0, CONFIG)
    assert applied.throttle_norm == 0.1


def test_first_step_allows_no_rise() -> None:
    _, applied, _ = interlock_step(InterlockState(gear=F), _drive(F, 1.0), 0.0, 5.0, CONFIG)
    assert applied.throttle_norm == 0.0


@pytest.mark.parametrize("now", [4.0, NAN])
def test_backward_or_nan_clock_allows_no_rise(now: float) -> None:
    _, applied, _ = interlock_step(_state(F, 0.2, at=5.0), _drive(F, 1.0), 0.0, now, CONFIG)
    assert applied.throttle_norm == 0.2


@pytest.mark.parametrize(
    "kwargs",
    [
        {"standstill_speed_mps": -0.1},
        {"direction_dwell_s": NAN},
        {"unknown_speed_dwell_s": INF},
        {"throttle_slew_up_per_s": 0.0},
        {"throttle_slew_up_per_s": INF},
    ],
)
def test_config_rejects_nonsense(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="must be finite"):
        InterlockConfig(**kwargs)


# --- properties over random request sequences -------------------------------------------------

WILD = st.sampled_from([NAN, INF, -INF, -1.0, 2.0])
UNIT = st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0), WILD)
STEER = st.one_of(st.floats(-1.0, 1.0), WILD)
SPEED = st.one_of(st.none(), st.just(0.0), st.floats(-0.1, 0.1), st.floats(-3.0, 3.0), WILD)
DT = st.one_of(st.sampled_from([0.0, 0.01, 0.1, 0.5]), st.floats(0.0, 2.0))
STEP = st.tuples(DT, st.builds(Movement, STEER, UNIT, UNIT, st.sampled_from(Gear)), SPEED)
# Mostly still, so that direction changes are granted often and the boundaries get hit.
STILL_THROTTLE = st.one_of(st.just(0.0), st.just(0.0), st.just(0.0), UNIT)
STILL_SPEED = st.one_of(st.just(0.0), st.none(), st.sampled_from([0.05, -0.05, 0.0500001]), SPEED)
STILL_DT = st.one_of(st.sampled_from([0.0, 0.1, 0.125, 0.25, 0.5, 1.0, 1.5]), DT)
STILL_STEP = st.tuples(
    STILL_DT, st.builds(Movement, STEER, STILL_THROTTLE, UNIT, st.sampled_from(Gear)), STILL_SPEED
)
# Runs of one repeated step hold their conditions long enough to pass (or just miss) a dwell.
RUNS = st.lists(st.tuples(st.one_of(STEP, STILL_STEP), st.integers(1, 8)), max_size=20).map(
    lambda runs: [step for step, count in runs for _ in range(count)]
)


@dataclass(frozen=True)
class Record:
    now: float
    requested: Movement
    speed_mps: float | None
    applied: Movement
    held: bool


def _simulate(steps: list[Step]) -> list[Record]:
    state, now, records = InterlockState(), 0.0, []
    for dt, requested, speed_mps in steps:
        now += dt
        state, applied, held = interlock_step(state, requested, speed_mps, now, CONFIG)
        records.append(Record(now, requested, speed_mps, applied, held))
    return records


def _zero_throttle(requested: Movement) -> bool:
    return not (math.isfinite(requested.throttle_norm) and requested.throttle_norm > 0.0)


def _measured(record: Record) -> float | None:
    speed = record.speed_mps
    return None if speed is None or math.isnan(speed) else speed


def _braking(requested: Movement) -> bool:
    brake = requested.brake_norm
    return not math.isfinite(brake) or brake >= CONFIG.unknown_speed_brake_norm


def _still(record: Record, speed_known: bool) -> bool:
    speed = _measured(record)
    slow = speed is not None and abs(speed) <= CONFIG.standstill_speed_mps
    unknown = speed is None and _braking(record.requested)
    return _zero_throttle(record.requested) and (slow if speed_known else slow or unknown)


def _settled_for_s(history: list[Record], speed_known: bool) -> float:
    """How long the trailing run of still records lasts (−1 if the last one is not still)."""
    start = None
    for record in reversed(history):
        if not _still(record, speed_known):
            break
        start = record.now
    return -1.0 if start is None else history[-1].now - start


@given(RUNS)
def test_direction_never_flips_unless_settled_for_the_dwell(steps: list[Step]) -> None:
    """Also through NEUTRAL: the last direction driven counts, not only the gear just before."""
    records = _simulate(steps)
    direction = N
    for index, record in enumerate(records):
        gear = record.applied.gear
        if gear is not N and direction is not N and gear is not direction:
            history = records[: index + 1]
            measured = _settled_for_s(history, speed_known=True) >= CONFIG.direction_dwell_s
            quiet = _settled_for_s(history, speed_known=False) >= CONFIG.unknown_speed_dwell_s
            assert measured or quiet
        direction = direction if gear is N else gear


@given(RUNS)
def test_direction_change_is_granted_once_settled_for_the_dwell(steps: list[Step]) -> None:
    """The other half of the rule: the interlock is no stricter than it says."""
    records = _simulate(steps)
    for index, record in enumerate(records):
        history = records[: index + 1]
        measured = _settled_for_s(history, speed_known=True) >= CONFIG.direction_dwell_s
        quiet = _settled_for_s(history, speed_known=False) >= CONFIG.unknown_speed_dwell_s
        if measured or quiet:
            assert (record.applied.gear, record.held) == (record.requested.gear, False)


@given(RUNS)
def test_no_direction_is_engaged_while_rolling_the_other_way(steps: list[Step]) -> None:
    previous_gear = N
    for record in _simulate(steps):
        gear, speed = record.applied.gear, _measured(record)
        if gear is not previous_gear and gear is not N and speed is not None:
            along_mps = speed if gear is F else -speed
            assert along_mps >= -CONFIG.standstill_speed_mps
        previous_gear = gear


@given(st.lists(STEP, max_size=60))
def test_throttle_zero_under_brake_and_never_above_request(steps: list[Step]) -> None:
    for record in _simulate(steps):
        requested_norm = record.requested.throttle_norm
        requested_norm = min(max(requested_norm, 0.0), 1.0) if math.isfinite(requested_norm) else 0
        assert record.applied.throttle_norm <= requested_norm
        if record.applied.brake_norm > 0.0 or record.held or record.applied.gear is N:
            assert record.applied.throttle_norm == 0.0


@given(st.lists(STEP, max_size=60))
def test_throttle_never_rises_faster_than_the_slew_limit(steps: list[Step]) -> None:
    previous_norm, previous_at = 0.0, 0.0
    for record in _simulate(steps):
        rise_limit = CONFIG.throttle_slew_up_per_s * (record.now - previous_at)
        assert record.applied.throttle_norm - previous_norm <= rise_limit + 1e-12
        previous_norm, previous_at = record.applied.throttle_norm, record.now


@given(st.lists(STEP, max_size=60), st.lists(st.floats(), max_size=60))
def test_outputs_always_in_range_whatever_comes_in(
    steps: list[Step],
    clock: list[float],
) -> None:
    """Also with any clock: NaN, infinite or backwards `now`."""
    state = InterlockState()
    for (_, requested, speed_mps), now in zip(steps, clock, strict=False):
        state, out, held = interlock_step(state, requested, speed_mps, now, CONFIG)
        assert -1.0 <= out.steering_norm <= 1.0
        assert 0.0 <= out.throttle_norm <= 1.0
        assert 0.0 <= out.brake_norm <= 1.0
        assert out.gear in Gear
        if held:
            assert out.throttle_norm == 0.0


@given(st.lists(STEP, max_size=60))
def test_neutral_is_always_granted_at_once(steps: list[Step]) -> None:
    for record in _simulate(steps):
        if record.requested.gear is N:
            assert (record.applied.gear, record.held) == (N, False)


# Tests added after mutation testing (docs/mutation.md). Interlocks at their exact edges: zero
# thresholds allowed, standstill speed inclusive, a throttle above full scale never reaching the
# drive however long the slew has had.


def test_zero_dwells_and_zero_standstill_speed_are_valid_settings() -> None:
    config = InterlockConfig(
        standstill_speed_mps=0.0, direction_dwell_s=0.0, unknown_speed_dwell_s=0.0
    )
    assert config.direction_dwell_s == 0.0


def test_a_negative_dwell_is_refused_with_a_message_saying_what_is_wrong() -> None:
    with pytest.raises(
        ValueError, match=r"^standstill speed, dwells and speed-check limits must be finite, >= 0$"
    ):
        InterlockConfig(direction_dwell_s=-0.1)


def test_a_bad_throttle_slew_is_refused_with_a_message_naming_it() -> None:
    with pytest.raises(ValueError, match=r"^throttle_slew_up_per_s must be finite and > 0$"):
        InterlockConfig(throttle_slew_up_per_s=0.0)


@pytest.mark.parametrize(
    ("gear", "speed_mps"),
    [
        (Gear.FORWARD, -0.03),  # rolling back, but slower than the standstill threshold
        (Gear.REVERSE, 0.03),
        (Gear.FORWARD, -0.05),  # exactly at the threshold: still standstill
        (Gear.REVERSE, 0.05),
    ],
)
def test_a_first_gear_is_granted_at_once_while_rolling_within_standstill(
    gear: Gear, speed_mps: float
) -> None:
    # No direction applied yet and throttle requested, so only the measured speed could hold it.
    requested = Movement(0.0, 0.5, 0.0, gear)
    _, applied, held = interlock_step(InterlockState(), requested, speed_mps, 0.0, CONFIG)
    assert not held
    assert applied.gear is gear


@pytest.mark.parametrize("gear", [Gear.FORWARD, Gear.REVERSE])
def test_a_first_gear_is_held_while_rolling_the_other_way_faster_than_standstill(
    gear: Gear,
) -> None:
    speed_mps = -0.06 if gear is Gear.FORWARD else 0.06
    requested = Movement(0.0, 0.5, 0.0, gear)
    _, applied, held = interlock_step(InterlockState(), requested, speed_mps, 0.0, CONFIG)
    assert held
    assert applied.gear is Gear.NEUTRAL
    assert applied.throttle_norm == 0.0


def test_a_throttle_above_full_scale_is_applied_as_full_scale_after_a_long_ramp() -> None:
    state = InterlockState(Gear.FORWARD, Gear.FORWARD, throttle_norm=1.0, updated_at=0.0)
    _, applied, _ = interlock_step(state, Movement(0.0, 1.5, 0.0, Gear.FORWARD), 0.0, 1.0, CONFIG)
    assert applied.throttle_norm == 1.0


@pytest.mark.parametrize("mode", list(ControlMode))
@pytest.mark.parametrize("faulted", [False, True])
def test_no_can_throttle_while_the_speed_check_has_faulted_the_sensor(
    mode: ControlMode, faulted: bool
) -> None:
    """Issue 41 finding 6: only CAN mode with SPEED_SENSOR_FAULT latched takes no throttle; RC
    keeps its operator's throttle, and a healthy sensor changes nothing."""
    assert can_throttle_allowed(mode, faulted) is not (faulted and mode is ControlMode.CAN)
