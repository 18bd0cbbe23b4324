"""Teleop keys and the dead man's rule, as pure functions: tables, edges and properties."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.model import Gear
from bywire.teleop.state import (
    HOLD_S,
    KEYS,
    RE_ENABLE_FRAMES,
    STEERING_DECAY_PER_S,
    THROTTLE_DECAY_PER_S,
    TeleopState,
    advance,
    help_line,
    press,
)

DRIVING = TeleopState(throttle_norm=0.5, brake_norm=0.0, gear=Gear.FORWARD)


def press_all(state: TeleopState, *keys: str, now_s: float = 0.0) -> TeleopState:
    for key in keys:
        state = press(state, key, now_s)
    return state


def test_the_initial_state_is_safe() -> None:
    state = TeleopState()
    assert (state.throttle_norm, state.brake_norm, state.gear) == (0.0, 1.0, Gear.NEUTRAL)
    assert not state.remote_stop
    assert not state.re_enable


@pytest.mark.parametrize(
    ("start", "keys", "expected"),
    [
        (TeleopState(), ("left",), {"steering_norm": -0.1}),
        (TeleopState(), ("right", "right"), {"steering_norm": 0.2}),
        (TeleopState(), ("left",) * 15, {"steering_norm": -1.0}),
        (TeleopState(), ("right",) * 15, {"steering_norm": 1.0}),
        (TeleopState(), ("up",), {"throttle_norm": 0.1, "brake_norm": 0.0}),
        (TeleopState(), ("up",) * 15, {"throttle_norm": 1.0, "brake_norm": 0.0}),
        (DRIVING, ("down",), {"throttle_norm": 0.4, "brake_norm": 0.0}),
        (DRIVING, ("down",) * 6, {"throttle_norm": 0.0, "brake_norm": 0.25}),
        (DRIVING, ("down",) * 20, {"throttle_norm": 0.0, "brake_norm": 1.0}),
        (DRIVING, ("space",), {"throttle_norm": 0.0, "brake_norm": 1.0}),
        (DRIVING, ("r",), {"gear": Gear.REVERSE, "throttle_norm": 0.0, "brake_norm": 0.0}),
        (DRIVING, ("n",), {"gear": Gear.NEUTRAL, "throttle_norm": 0.0}),
        (TeleopState(), ("f",), {"gear": Gear.FORWARD}),
        (TeleopState(), ("z",), {"turn_left": True, "turn_right": False}),
        (TeleopState(), ("z", "z"), {"turn_left": False}),
        (TeleopState(), ("z", "x"), {"turn_left": False, "turn_right": True}),
        (TeleopState(), ("x", "z"), {"turn_left": True, "turn_right": False}),
        (TeleopState(), ("h",), {"hazard": True}),
        (TeleopState(), ("h", "h"), {"hazard": False}),
        (TeleopState(), ("l",), {"low_beam": True}),
        (TeleopState(), ("s",), {"remote_stop": True}),
        (TeleopState(), ("s", "s"), {"remote_stop": False}),
        (TeleopState(), ("e",), {"re_enable": True}),
        (DRIVING, ("q", "a", "escape", "enter"), {"throttle_norm": 0.5, "gear": Gear.FORWARD}),
    ],
)
def test_key_table(start: TeleopState, keys: tuple[str, ...], expected: dict[str, object]) -> None:
    state = press_all(start, *keys)
    assert {name: getattr(state, name) for name in expected} == expected


def test_unknown_keys_leave_the_state_as_it_was() -> None:
    assert press(DRIVING, "q", 1.0) is DRIVING


def test_every_key_is_in_the_help_line_once() -> None:
    line = help_line()
    for binding in KEYS:
        assert line.count(f"{binding.key}: {binding.label}") == 1
    assert len({binding.key for binding in KEYS}) == len(KEYS)


def test_drive_keys_and_steering_keys_stamp_their_own_time() -> None:
    state = press(press(TeleopState(), "up", 1.0), "left", 2.0)
    assert (state.drive_key_at_s, state.steer_key_at_s) == (1.0, 2.0)
    lights = press(state, "z", 3.0)
    assert (lights.drive_key_at_s, lights.steer_key_at_s) == (1.0, 2.0)


def _advance_every_period(state: TeleopState, from_s: float, to_s: float) -> TeleopState:
    periods = round((to_s - from_s) / 0.02)
    for index in range(periods + 1):
        state = advance(state, from_s + index * 0.02)
    return state


def test_held_set_points_stay_within_the_hold_time() -> None:
    state = press_all(TeleopState(), "up", "up", "right", now_s=0.0)
    state = _advance_every_period(state, 0.0, HOLD_S)
    assert (state.throttle_norm, state.steering_norm) == (0.2, 0.1)


def test_after_the_hold_time_throttle_and_steering_ramp_to_zero_at_their_rates() -> None:
    state = press_all(TeleopState(), *("up",) * 8, *("left",) * 8, now_s=0.0)
    state = advance(state, HOLD_S + 0.1)
    state = advance(state, HOLD_S + 0.3)
    assert state.throttle_norm == pytest.approx(0.8 - THROTTLE_DECAY_PER_S * 0.2)
    assert state.steering_norm == pytest.approx(-0.8 + STEERING_DECAY_PER_S * 0.2)
    state = _advance_every_period(state, HOLD_S + 0.3, HOLD_S + 5.0)
    assert (state.throttle_norm, state.steering_norm) == (0.0, 0.0)
    assert state.brake_norm == 0.0  # decay never touches the brake


def test_steering_returns_from_the_right_without_overshooting() -> None:
    state = press(TeleopState(), "right", 0.0)
    state = advance(state, 1.0)
    state = advance(state, 10.0)
    assert state.steering_norm == 0.0


def test_a_key_press_restarts_the_hold_time() -> None:
    state = press_all(TeleopState(), "up", "up", now_s=0.0)
    state = advance(state, 0.5)
    state = press(state, "up", 0.5)
    state = advance(state, 1.0)
    assert state.throttle_norm == pytest.approx(0.3)


def _re_enable_sequence(state: TeleopState, periods: int, press_at: set[int]) -> list[bool]:
    sent = []
    for period in range(periods):
        if period in press_at:
            state = press(state, "e", period * 0.02)
        sent.append(state.re_enable)
        state = advance(state, period * 0.02)
    return sent


def test_re_enable_is_a_pulse_with_a_low_period_after_it() -> None:
    sent = _re_enable_sequence(TeleopState(), 10, {0})
    assert sent == [True] * RE_ENABLE_FRAMES + [False] * (10 - RE_ENABLE_FRAMES)


def test_pressing_re_enable_during_a_pulse_neither_extends_nor_merges_it() -> None:
    sent = _re_enable_sequence(TeleopState(), 14, {0, 2, RE_ENABLE_FRAMES})
    assert sent[: RE_ENABLE_FRAMES + 1] == [True] * RE_ENABLE_FRAMES + [False]
    assert sent[RE_ENABLE_FRAMES + 1 :] == [False] * (14 - RE_ENABLE_FRAMES - 1)


def test_a_second_re_enable_after_the_pulse_gives_a_new_rising_edge() -> None:
    sent = _re_enable_sequence(TeleopState(), 14, {0, RE_ENABLE_FRAMES + 1})
    rising = [index for index in range(1, 14) if sent[index] and not sent[index - 1]]
    assert sent[0]
    assert rising == [RE_ENABLE_FRAMES + 1]


@given(
    st.lists(st.sampled_from([binding.key for binding in KEYS]), max_size=60),
    st.lists(st.floats(0.0, 0.1), max_size=60),
)
def test_any_key_sequence_keeps_every_set_point_in_range(
    keys: list[str], gaps_s: list[float]
) -> None:
    state, now_s = TeleopState(), 0.0
    for key, gap_s in zip(keys, gaps_s + [0.02] * len(keys), strict=False):
        now_s += gap_s
        state = advance(press(state, key, now_s), now_s)
        assert -1.0 <= state.steering_norm <= 1.0
        assert 0.0 <= state.throttle_norm <= 1.0
        assert 0.0 <= state.brake_norm <= 1.0
        assert 0 <= state.re_enable_pulse <= RE_ENABLE_FRAMES + 1
