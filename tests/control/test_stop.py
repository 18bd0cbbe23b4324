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

CONFIG = StopConfig(controlled_max_s=2.5, controlled_min_decel_mps2=0.5, standstill_mps=0.05)


def _run(
    speeds: Sequence[float | None],
    *,
    category: StopCategory = StopCategory.CONTROLLED,
    powered: bool = True,
    period_s: float = 0.01,
) -> list[StopPhase]:
    state, phases = NOT_STOPPING, []
    for tick, speed in enumerate(speeds):
        state, phase = stop_step(
            state,
            stopping=True,
            category=category,
            powered=powered,
            speed_mps=speed,
            now=tick * period_s,
            config=CONFIG,
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
    assert speeds[first_off] <= CONFIG.standstill_mps
    assert phases[-1] is StopPhase.POWER_OFF  # a reading above standstill never re-powers it


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
