"""The E-stop's wiring rule and debounce (issue 44): low is pressed, and pressed wins."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from bywire.control.estop import BOUNCE_S, NOT_PRESSED, EstopState, estop_step, pressed_by_level

PERIOD_S = 0.010


def _holds(samples: Sequence[tuple[float, bool | None]]) -> list[bool]:
    state = NOT_PRESSED
    held = []
    for now, level_high in samples:
        state = estop_step(state, level_high, now)
        held.append(state.holds(now))
    return held


def test_low_is_pressed_and_high_is_released() -> None:
    # the wiring rule: a broken wire or a dead line reads low, as a press does
    assert pressed_by_level(False)
    assert not pressed_by_level(True)


def test_no_estop_wired_never_holds() -> None:
    assert _holds([(0.0, None), (0.01, None)]) == [False, False]


def test_one_low_sample_holds_at_once_and_until_high_for_the_bounce_time() -> None:
    samples = [(0.0, True), (0.01, False)] + [(0.01 + n * 0.005, True) for n in range(1, 7)]
    held = _holds(samples)
    assert held[0] is False
    assert held[1] is True  # pressed wins: at the first low sample
    # high at 0.015 .. 0.040: still held until 0.01 + BOUNCE_S, released from then on
    expected = [now - 0.01 < BOUNCE_S for now, _ in samples[2:]]
    assert held[2:] == expected
    assert expected[-1] is False
    assert True in expected


def test_chatter_holds_throughout_and_a_bounce_back_to_high_does_not_release() -> None:
    # alternating every sample for 100 ms: never a release, however many highs
    samples = [(n * 0.001, n % 2 == 1) for n in range(100)]
    assert all(_holds(samples))


@pytest.mark.parametrize("start_s", [0.0, 123.456])
def test_the_state_is_only_when_it_last_read_pressed(start_s: float) -> None:
    state = estop_step(NOT_PRESSED, False, start_s)
    assert state == EstopState(start_s)
    assert estop_step(state, True, start_s + 1.0) == state  # high changes nothing
    assert state.holds(start_s + BOUNCE_S - 1e-9)
    assert not state.holds(start_s + BOUNCE_S + 1e-9)
