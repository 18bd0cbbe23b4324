"""Blinking at its exact edges: the lit half excludes the half-period instant; the rate is used."""

from __future__ import annotations

from bywire.control.lights import LightRequest, blink_phase_on, light_outputs


def test_the_lit_half_of_a_blink_ends_exactly_at_half_a_period() -> None:
    assert blink_phase_on(0.0, 1.0)
    assert blink_phase_on(0.499, 1.0)
    assert not blink_phase_on(0.5, 1.0)


def test_light_outputs_blink_at_the_rate_asked_for() -> None:
    hazard = LightRequest(hazard=True)
    # t = 0.5 s: dark half at the default 1.5 Hz (phase 0.75), lit half at 0.5 Hz (phase 0.25)
    assert not light_outputs(hazard, 0.5).turn_left
    assert light_outputs(hazard, 0.5, blink_rate_hz=0.5).turn_left
