"""The speed governor: cap and brake against the speed, their rate bound, the ceiling without a
trusted speed, and no effect at all without a limit."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.governor import (
    IDLE,
    RATE_PER_S,
    GovernorConfig,
    GovernorState,
    acting,
    ceiling_throttle,
    governed,
    governor_step,
    interpolate,
)
from bywire.control.mux import Movement
from bywire.model import Gear

LIMIT = 2.5  # band 0.5 (cap 1 below 2.0, 0 at 2.5), margin 0.25 (brake from 2.75, full at 3.0)
CEILING = 0.462
CONFIG = GovernorConfig(LIMIT, CEILING)
FULL = Movement(0.0, 1.0, 0.0, Gear.FORWARD)


def settled(speed_mps: float | None, config: GovernorConfig = CONFIG) -> GovernorState:
    """The governor after long enough at one speed for its rate bound not to matter."""
    state = governor_step(IDLE, speed_mps, True, 0.0, config)
    for tick in range(1, 200):
        state = governor_step(state, speed_mps, True, tick * 0.01, config)
    return state


@pytest.mark.parametrize(
    ("speed", "cap", "brake"),
    [
        (0.0, 1.0, 0.0),
        (2.0, 1.0, 0.0),  # the band's lower edge: nothing taken yet
        (2.25, 0.5, 0.0),  # half way through the band
        (2.5, 0.0, 0.0),  # at the limit: no throttle, no brake
        (2.75, 0.0, 0.0),  # the margin: a small overshoot is not braked
        (2.875, 0.0, 0.5),
        (3.0, 0.0, 1.0),
        (9.0, 0.0, 1.0),
        (-2.25, 0.5, 0.0),  # reverse: the same limit on the magnitude
        (-2.875, 0.0, 0.5),
    ],
)
def test_cap_and_brake_follow_the_speed(speed: float, cap: float, brake: float) -> None:
    state = settled(speed)
    assert state.cap_norm == pytest.approx(cap)
    assert state.brake_norm == pytest.approx(brake)


def test_without_a_trusted_speed_the_cap_is_the_ceiling_and_nothing_brakes() -> None:
    state = settled(None)
    assert (state.cap_norm, state.brake_norm) == (CEILING, 0.0)
    assert governed(FULL, state).throttle_norm == CEILING
    assert settled(math.nan).cap_norm == CEILING


def test_the_ceiling_is_the_calibrated_throttle_that_holds_the_limit() -> None:
    speeds, throttles = (0.0, 2.0, 3.0), (0.1, 0.3, 0.8)
    assert ceiling_throttle(2.5, speeds, throttles) == pytest.approx(0.55)
    assert ceiling_throttle(9.0, speeds, throttles) == 0.8  # beyond the map: its last, not 1
    assert interpolate(speeds, throttles, -1.0) == 0.1


def test_without_a_limit_or_while_not_driving_nothing_is_governed() -> None:
    assert governor_step(settled(3.0), 3.0, False, 5.0, CONFIG) == IDLE
    free = GovernorConfig(None)
    assert governor_step(IDLE, 9.0, True, 0.0, free) == IDLE
    assert governed(FULL, IDLE) is FULL
    assert not acting(FULL, IDLE)


def test_an_arming_starts_from_the_targets() -> None:
    state = governor_step(IDLE, 2.9, True, 1.0, CONFIG)
    assert state.cap_norm == 0.0
    assert state.brake_norm == pytest.approx(0.6)


def test_a_speed_jump_moves_cap_and_brake_at_the_rate_bound_only() -> None:
    state = settled(1.0)
    state = governor_step(state, 3.0, True, 2.0, CONFIG)  # 10 ms after the last settled step
    assert state.cap_norm == pytest.approx(1.0 - RATE_PER_S * 0.01)
    assert state.brake_norm == 0.0  # no brake while the cap is still coming down


def test_the_brake_begins_only_once_the_cap_is_down() -> None:
    state, now = settled(1.0), 1.99
    while state.cap_norm > 0.0:
        now += 0.01
        state = governor_step(state, 3.0, True, now, CONFIG)
        assert state.brake_norm == 0.0 or state.cap_norm == 0.0
    assert governor_step(state, 3.0, True, now + 0.01, CONFIG).brake_norm > 0.0


def test_a_cap_coming_down_starts_from_the_throttle_asked() -> None:
    """Above the throttle asked the cap holds nothing back: it comes down from there, and the
    brake need not wait for it (docs/SAFETY.md row 71)."""
    coasting = governor_step(settled(1.0), 3.0, True, 2.0, CONFIG, asked_throttle_norm=0.0)
    assert coasting.cap_norm == 0.0
    assert (
        governor_step(coasting, 3.0, True, 2.01, CONFIG, asked_throttle_norm=0.0).brake_norm > 0.0
    )
    part = governor_step(settled(1.0), 3.0, True, 2.0, CONFIG, asked_throttle_norm=0.3)
    assert part.cap_norm == pytest.approx(0.3 - RATE_PER_S * 0.01)
    rising = governor_step(settled(2.25), 0.0, True, 2.0, CONFIG, asked_throttle_norm=0.0)
    assert rising.cap_norm == pytest.approx(0.5 + RATE_PER_S * 0.01)  # going up: the rate bound


@given(
    speeds=st.lists(
        st.one_of(st.none(), st.floats(-10.0, 10.0), st.just(math.nan)), min_size=2, max_size=50
    ),
    gaps=st.lists(st.floats(0.0, 0.05), min_size=50, max_size=50),
    asked=st.lists(st.floats(0.0, 1.0), min_size=50, max_size=50),
)
def test_never_a_jerk(speeds: list[float | None], gaps: list[float], asked: list[float]) -> None:
    """Whatever the readings (jumps, gaps, NaN, loss of trust) and the throttle asked, the
    throttle the cap lets through and the brake each move at most RATE_PER_S times the time
    since the last step, for the same throttle asked (the cap itself may drop to the throttle
    asked: above it, it moves no output)."""
    state, now = governor_step(IDLE, speeds[0], True, 0.0, CONFIG), 0.0
    for speed, gap, throttle in zip(speeds[1:], gaps, asked, strict=False):
        now += gap
        new = governor_step(state, speed, True, now, CONFIG, asked_throttle_norm=throttle)
        bound = RATE_PER_S * gap + 1e-12
        assert abs(min(throttle, new.cap_norm) - min(throttle, state.cap_norm)) <= bound
        assert abs(new.brake_norm - state.brake_norm) <= bound
        assert 0.0 <= new.cap_norm <= 1.0
        assert 0.0 <= new.brake_norm <= 1.0
        state = new


def test_governed_caps_the_throttle_and_adds_the_brake() -> None:
    capped = GovernorState(0.5, 0.0, 1.0)
    assert governed(FULL, capped) == Movement(0.0, 0.5, 0.0, Gear.FORWARD)
    assert acting(FULL, capped)
    assert not acting(Movement(0.0, 0.3, 0.0, Gear.FORWARD), capped)  # asked less than the cap
    braking = GovernorState(0.0, 0.4, 1.0)
    assert governed(FULL, braking) == Movement(0.0, 0.0, 0.4, Gear.FORWARD)
    harder = Movement(0.0, 0.0, 0.9, Gear.FORWARD)
    assert governed(harder, braking).brake_norm == 0.9  # the operator's harder brake stands
    assert acting(Movement(0.0, 0.0, 0.0, Gear.FORWARD), braking)
