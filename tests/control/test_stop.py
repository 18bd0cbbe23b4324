"""Stop categories: a controlled stop keeps the drive powered to brake, and only while it should."""

from __future__ import annotations

from collections.abc import Sequence

from hypothesis import given
from hypothesis import strategies as st

from bywire.control.interlocks import InterlockConfig
from bywire.control.speed_check import SpeedCheckState, speed_check_step
from bywire.control.stop import (
    GRACE_S,
    NOT_STOPPING,
    STANDSTILL_LIMIT_MPS,
    StopCategory,
    StopConfig,
    StopPhase,
    StopState,
    standstill_proven_since,
    stop_step,
)
from bywire.control.supervisor import Cause, stop_category

CONFIG = StopConfig(
    controlled_max_s=2.5, controlled_min_decel_mps2=0.5, standstill_mps=0.05, standstill_hold_s=0.3
)
HOLD_TICKS = 30  # standstill_hold_s at 10 ms a pass


def _sensor(state: SpeedCheckState, speed: float | None, now: float) -> SpeedCheckState:
    """The speed check after a reading, as the controller runs it (no throttle applied)."""
    return speed_check_step(state, speed, 0.0, now, InterlockConfig())


def _proven(sensor: SpeedCheckState) -> float | None:
    return standstill_proven_since(sensor.standstill_since, sensor.standstill_abrupt, CONFIG)


def _run(
    speeds: Sequence[float | None],
    *,
    category: StopCategory = StopCategory.CONTROLLED,
    powered: bool = True,
    period_s: float = 0.01,
    sensor: SpeedCheckState | None = None,
) -> list[StopPhase]:
    """The phases over `speeds`, one a pass from 0 s (`sensor`: the speed check before)."""
    state, phases = NOT_STOPPING, []
    sensor = SpeedCheckState(1.0, -period_s) if sensor is None else sensor
    for tick, speed in enumerate(speeds):
        now = tick * period_s
        sensor = _sensor(sensor, speed, now)
        state, phase = stop_step(
            state,
            stopping=True,
            category=category,
            powered=powered,
            speed_mps=speed,
            now=now,
            config=CONFIG,
            standstill_proven_s=_proven(sensor),
        )
        phases.append(phase)
    return phases


def test_a_stop_that_begins_with_the_drive_off_is_category_0() -> None:
    assert _run([1.0, 1.0], powered=False) == [StopPhase.POWER_OFF] * 2


def test_a_category_0_cause_removes_power_at_once() -> None:
    assert _run([1.5], category=StopCategory.POWER_OFF) == [StopPhase.POWER_OFF]


def test_a_controlled_stop_brakes_powered_until_standstill_then_powers_off_for_good() -> None:
    speeds = [1.5 - 1.5 * tick * 0.01 for tick in range(100)] + [0.0, 0.0, 0.3]
    phases = _run(speeds)
    first_off = phases.index(StopPhase.POWER_OFF)
    assert set(phases[:first_off]) == {StopPhase.BRAKING}
    assert speeds[first_off] <= CONFIG.standstill_mps < speeds[first_off - 1]  # at once: the
    assert speeds[first_off - 1] <= STANDSTILL_LIMIT_MPS  # readings slowed into it
    assert phases[-1] is StopPhase.POWER_OFF  # a reading above standstill never re-powers it


def test_an_abrupt_standstill_ends_the_stop_only_once_it_has_been_read_for_the_hold() -> None:
    # A wheel sensor that dies at 0.3 m/s (inside its check's blind spot) reads 0 at once: the
    # drive keeps regenerating for the hold (1.5 m/s² stops the robot from 0.45 m/s within it).
    phases = _run([0.3] * 10 + [0.0] * (HOLD_TICKS + 2))
    assert phases[: 10 + HOLD_TICKS] == [StopPhase.BRAKING] * (10 + HOLD_TICKS)
    assert phases[10 + HOLD_TICKS] is StopPhase.POWER_OFF
    # from just above the standstill limit, and after a gap in the readings, too
    assert _run([0.11] + [0.0] * HOLD_TICKS)[-1] is StopPhase.BRAKING
    assert _run([0.5, None] + [0.0] * HOLD_TICKS)[-1] is StopPhase.BRAKING
    # from a reading at the limit, a braking robot's: at once
    assert _run([0.5, 0.1, 0.0])[-1] is StopPhase.POWER_OFF


def test_a_robot_that_stood_before_the_stop_is_switched_off_at_once() -> None:
    stood = SpeedCheckState(0.0, -0.01, standstill_since=-0.3, standstill_abrupt=True)
    assert _run([0.0], sensor=stood) == [StopPhase.POWER_OFF]
    halted_just_now = SpeedCheckState(0.0, -0.01, standstill_since=-0.15, standstill_abrupt=True)
    phases = _run([0.0] * (HOLD_TICKS // 2 + 1), sensor=halted_just_now)
    assert phases[-2:] == [StopPhase.BRAKING, StopPhase.POWER_OFF]


def test_a_reading_of_motion_starts_the_hold_afresh() -> None:
    speeds = [0.5] + [0.0] * (HOLD_TICKS - 5) + [0.2] + [0.0] * (HOLD_TICKS - 5)
    assert set(_run(speeds)) == {StopPhase.BRAKING}


def test_without_a_speed_the_time_bound_ends_it() -> None:
    phases = _run([None] * 300)
    assert phases.index(StopPhase.POWER_OFF) * 0.01 == CONFIG.controlled_max_s


def test_a_robot_that_does_not_slow_is_switched_off_and_flagged() -> None:
    state, phase = NOT_STOPPING, StopPhase.DRIVING
    for tick in range(100):
        state, phase = stop_step(
            state,
            stopping=True,
            category=StopCategory.CONTROLLED,
            powered=True,
            speed_mps=1.5,
            now=tick * 0.01,
            config=CONFIG,
            standstill_proven_s=None,
        )
        if phase is StopPhase.POWER_OFF:
            break
    assert phase is StopPhase.POWER_OFF
    assert state.escalated
    assert tick * 0.01 > GRACE_S  # the brakes had their time to bite


def test_leaving_stop_forgets_the_stop() -> None:
    state, _ = stop_step(
        StopState(since_s=0.0, power_off=True),
        stopping=False,
        category=StopCategory.CONTROLLED,
        powered=True,
        speed_mps=1.0,
        now=1.0,
        config=CONFIG,
        standstill_proven_s=None,
    )
    assert state == NOT_STOPPING


@given(
    st.lists(st.one_of(st.none(), st.floats(-5.0, 5.0)), min_size=1, max_size=400),
    st.sampled_from(StopCategory),
    st.booleans(),
)
def test_power_never_comes_back_within_a_stop_and_never_outlasts_the_bound(
    speeds: list[float | None], category: StopCategory, powered: bool
) -> None:
    phases = _run(speeds, category=category, powered=powered)
    if StopPhase.POWER_OFF in phases:
        first_off = phases.index(StopPhase.POWER_OFF)
        assert set(phases[first_off:]) == {StopPhase.POWER_OFF}
    assert all(
        phase is StopPhase.POWER_OFF
        for tick, phase in enumerate(phases)
        if tick * 0.01 >= CONFIG.controlled_max_s
    )
    if category is StopCategory.POWER_OFF or not powered:
        assert set(phases) == {StopPhase.POWER_OFF}


def test_every_cause_names_its_category_and_a_suspect_drive_is_category_0() -> None:
    # ...and the E-stop, category 0 by its standard (ISO 13850, the issue 44 acceptance)
    suspect = {Cause.DAC_FAULT, Cause.WATCHDOG, Cause.TIMING, Cause.POWER_UP, Cause.ESTOP}
    assert {c for c in Cause if c.category is StopCategory.POWER_OFF} == suspect
    assert stop_category(frozenset()) is StopCategory.CONTROLLED  # the switch at STOP
    assert stop_category(frozenset({Cause.RC_LOST})) is StopCategory.CONTROLLED
    assert stop_category(frozenset({Cause.RC_LOST, Cause.DAC_FAULT})) is StopCategory.POWER_OFF


@given(st.lists(st.one_of(st.none(), st.floats(0.0, 0.3)), min_size=1, max_size=240))
def test_power_goes_off_for_a_standstill_only_once_it_is_proven(speeds: list[float | None]) -> None:
    """Off for a standstill only after the hold, or at once when the readings slowed into it."""
    state, sensor = NOT_STOPPING, SpeedCheckState(1.0, -0.01)
    for tick, speed in enumerate(speeds):
        sensor = _sensor(sensor, speed, tick * 0.01)
        state, phase = stop_step(
            state,
            stopping=True,
            category=StopCategory.CONTROLLED,
            powered=True,
            speed_mps=speed,
            now=tick * 0.01,
            config=CONFIG,
            standstill_proven_s=_proven(sensor),
        )
        if phase is StopPhase.POWER_OFF:
            break
    else:
        return
    if state.escalated or tick * 0.01 >= CONFIG.controlled_max_s:
        return
    start = tick  # the run of standstill readings that ended the stop
    while start > 0 and (s := speeds[start - 1]) is not None and s <= CONFIG.standstill_mps:
        start -= 1
    before = speeds[start - 1] if start > 0 else 1.0  # the sensor's state before: 1 m/s
    slowed_into_it = before is not None and before <= STANDSTILL_LIMIT_MPS
    assert tick - start >= HOLD_TICKS or slowed_into_it
