"""Stop categories: a controlled stop keeps the drive powered to brake, and only while it should."""

from __future__ import annotations

from collections.abc import Sequence

from hypothesis import given
from hypothesis import strategies as st

from bywire.control.stop import (
    GRACE_S,
    NOT_STOPPING,
    StopCategory,
    StopConfig,
    StopPhase,
    StopState,
    stop_step,
)
from bywire.control.supervisor import Cause, stop_category

CONFIG = StopConfig(
    controlled_max_s=2.5, controlled_min_decel_mps2=0.5, standstill_mps=0.05, standstill_hold_s=0.3
)
HOLD_TICKS = 30  # standstill_hold_s at 10 ms a pass


def _standstill_since(since: float | None, speed: float | None, now: float) -> float | None:
    """What the speed check says (`SpeedCheckState.standstill_since`) after a reading."""
    if speed is None or abs(speed) > CONFIG.standstill_mps:
        return None
    return now if since is None else since


def _run(
    speeds: Sequence[float | None],
    *,
    category: StopCategory = StopCategory.CONTROLLED,
    powered: bool = True,
    period_s: float = 0.01,
    standing_since_s: float | None = None,
) -> list[StopPhase]:
    """The phases over `speeds`, one a pass from 0 s (`standing_since_s`: the robot stood
    before the stop, read since then)."""
    state, phases, since = NOT_STOPPING, [], standing_since_s
    for tick, speed in enumerate(speeds):
        now = tick * period_s
        since = _standstill_since(since, speed, now)
        state, phase = stop_step(
            state,
            stopping=True,
            category=category,
            powered=powered,
            speed_mps=speed,
            now=now,
            config=CONFIG,
            standstill_since_s=since,
        )
        phases.append(phase)
    return phases


def test_a_stop_that_begins_with_the_drive_off_is_category_0() -> None:
    assert _run([1.0, 1.0], powered=False) == [StopPhase.POWER_OFF] * 2


def test_a_category_0_cause_removes_power_at_once() -> None:
    assert _run([1.5], category=StopCategory.POWER_OFF) == [StopPhase.POWER_OFF]


def test_a_controlled_stop_brakes_powered_until_standstill_then_powers_off_for_good() -> None:
    speeds = [1.5 - 1.5 * tick * 0.01 for tick in range(100)] + [0.0] * (HOLD_TICKS + 1) + [0.3]
    phases = _run(speeds)
    first_off = phases.index(StopPhase.POWER_OFF)
    assert set(phases[:first_off]) == {StopPhase.BRAKING}
    held = speeds[first_off - HOLD_TICKS : first_off + 1]
    assert max(held) <= CONFIG.standstill_mps  # standstill, held
    assert speeds[first_off - HOLD_TICKS - 1] > CONFIG.standstill_mps  # and not a pass longer
    assert phases[-1] is StopPhase.POWER_OFF  # a reading above standstill never re-powers it


def test_a_standstill_ends_the_stop_only_once_it_has_been_read_for_the_hold() -> None:
    # A wheel sensor that dies at 0.3 m/s (inside its check's blind spot) reads 0 at once: the
    # drive keeps regenerating for the hold (1.5 m/s² stops the robot from 0.45 m/s within it).
    phases = _run([0.3] * 10 + [0.0] * (HOLD_TICKS + 2))
    assert phases[: 10 + HOLD_TICKS] == [StopPhase.BRAKING] * (10 + HOLD_TICKS)
    assert phases[10 + HOLD_TICKS] is StopPhase.POWER_OFF


def test_a_robot_that_stood_before_the_stop_is_switched_off_at_once() -> None:
    assert _run([0.0], standing_since_s=-CONFIG.standstill_hold_s) == [StopPhase.POWER_OFF]
    halted_just_now = _run([0.0] * (HOLD_TICKS // 2 + 1), standing_since_s=-0.15)
    assert halted_just_now[-2:] == [StopPhase.BRAKING, StopPhase.POWER_OFF]


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
            standstill_since_s=None,
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
        standstill_since_s=None,
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
def test_power_goes_off_for_a_standstill_only_after_the_hold(speeds: list[float | None]) -> None:
    state, since = NOT_STOPPING, None
    for tick, speed in enumerate(speeds):
        since = _standstill_since(since, speed, tick * 0.01)
        state, phase = stop_step(
            state,
            stopping=True,
            category=StopCategory.CONTROLLED,
            powered=True,
            speed_mps=speed,
            now=tick * 0.01,
            config=CONFIG,
            standstill_since_s=since,
        )
        if phase is StopPhase.POWER_OFF:
            break
    else:
        return
    held = speeds[max(tick - HOLD_TICKS, 0) : tick + 1]
    standstill = all(s is not None and s <= CONFIG.standstill_mps for s in held)
    timed_out = tick * 0.01 >= CONFIG.controlled_max_s
    assert (standstill and tick >= HOLD_TICKS) or timed_out or state.escalated
