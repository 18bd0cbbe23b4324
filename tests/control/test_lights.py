"""Lights: thresholds, blinking at 1.5 Hz, error LED."""

from __future__ import annotations

import itertools
import math

import pytest

from bywire.control.lights import LightOutputs, LightRequest, blink_phase_on, light_outputs


@pytest.mark.parametrize(
    ("brake_norm", "lit"),
    [(0.0, False), (0.10, False), (0.1001, True), (0.5, True), (math.nan, True)],
)
def test_brake_lights_above_ten_percent(brake_norm: float, lit: bool) -> None:
    assert light_outputs(LightRequest(brake_norm=brake_norm), now=0.0).brake is lit


def test_reverse_lights_follow_reverse_gear() -> None:
    assert light_outputs(LightRequest(reverse_gear=True), 0.0).reverse
    assert not light_outputs(LightRequest(reverse_gear=False), 0.0).reverse


def test_error_led_on_any_flag() -> None:
    assert light_outputs(LightRequest(error_flags=1 << 63), 0.0).error_led
    assert not light_outputs(LightRequest(error_flags=0), 0.0).error_led


def _edges(request: LightRequest, side: str) -> list[float]:
    """Rising edges over ten seconds sampled every millisecond."""
    step_s = 0.001
    levels = [getattr(light_outputs(request, tick * step_s), side) for tick in range(10_000)]
    return [
        tick * step_s for tick in range(1, len(levels)) if levels[tick] and not levels[tick - 1]
    ]


@pytest.mark.parametrize("side", ["turn_left", "turn_right"])
def test_turn_signal_blinks_at_one_and_a_half_hertz_with_half_duty(side: str) -> None:
    request = LightRequest(**{side: True})
    rising = _edges(request, side)
    periods = [later - earlier for earlier, later in itertools.pairwise(rising)]
    assert len(rising) == 14  # on from t = 0, so the first rise is at 2/3 s
    assert all(period == pytest.approx(1 / 1.5, abs=0.002) for period in periods)
    samples = [getattr(light_outputs(request, tick * 0.001), side) for tick in range(6000)]
    assert sum(samples) / len(samples) == pytest.approx(0.5, abs=0.01)


def test_only_the_requested_side_blinks() -> None:
    outputs = light_outputs(LightRequest(turn_left=True), now=0.1)
    assert outputs.turn_left
    assert not outputs.turn_right


def test_hazard_blinks_both_sides_in_step() -> None:
    for tick in range(200):
        outputs = light_outputs(LightRequest(hazard=True), now=tick * 0.01)
        assert outputs.turn_left == outputs.turn_right
    assert light_outputs(LightRequest(hazard=True), now=0.1).turn_left
    assert not light_outputs(LightRequest(hazard=True), now=0.5).turn_left


def test_nothing_requested_means_all_dark() -> None:
    assert light_outputs(LightRequest(), now=0.2) == LightOutputs()


# Tests added after mutation testing (docs/mutation.md). Blinking at its exact edges: the lit half
# excludes the half-period instant; the rate is used.


def test_the_lit_half_of_a_blink_ends_exactly_at_half_a_period() -> None:
    assert blink_phase_on(0.0, 1.0)
    assert blink_phase_on(0.499, 1.0)
    assert not blink_phase_on(0.5, 1.0)


def test_light_outputs_blink_at_the_rate_asked_for() -> None:
    hazard = LightRequest(hazard=True)
    # t = 0.5 s: dark half at the default 1.5 Hz (phase 0.75), lit half at 0.5 Hz (phase 0.25)
    assert not light_outputs(hazard, 0.5).turn_left
    assert light_outputs(hazard, 0.5, blink_rate_hz=0.5).turn_left
