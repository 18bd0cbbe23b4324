"""RC mapping at its exact edges: deadband, end stops, switch thresholds, short frames, hazard."""

from __future__ import annotations

import pytest

from bywire.control.rc_mapping import (
    AxisCalibration,
    RcMapping,
    SwitchCalibration,
    axis_norm,
    channels_plausible,
    in_failsafe,
    rc_request,
    switch_position,
)

CENTRED = (1500,) * 14


def test_a_stick_exactly_at_the_deadband_edge_is_outside_the_deadband() -> None:
    # 10 µs of a 500 µs half-range is exactly the default deadband of 0.02
    assert axis_norm(1510, AxisCalibration(channel=0)) == 0.02
    assert axis_norm(1509, AxisCalibration(channel=0)) == 0.0


@pytest.mark.parametrize(("raw", "norm"), [(800, -1.0), (900, -1.0), (2200, 1.0)])
def test_a_stick_beyond_its_calibrated_end_stops_is_clamped_to_full_scale(
    raw: int, norm: float
) -> None:
    assert axis_norm(raw, AxisCalibration(channel=1)) == norm


@pytest.mark.parametrize(
    ("raw", "position"),
    [(1249, 0), (1250, 1), (1500, 1), (1750, 1), (1751, 2)],
)
def test_switch_thresholds_are_1250_and_1750_inclusive_of_the_middle(
    raw: int, position: int
) -> None:
    assert switch_position(raw, SwitchCalibration(channel=6)) == position


def test_a_frame_too_short_for_the_used_channels_is_implausible_not_a_crash() -> None:
    mapping = RcMapping()
    short = CENTRED[:8]  # the hazard switch is channel 8
    assert not channels_plausible(short, mapping)
    assert rc_request(short, mapping) is None


def test_a_frame_too_short_for_the_failsafe_channel_is_not_failsafe_output() -> None:
    mapping = RcMapping()
    assert not in_failsafe(CENTRED[:1], mapping)
    assert rc_request(CENTRED[:1], mapping) is None  # and still refused: too short to use


def test_the_hazard_switch_up_asks_for_hazard_lights() -> None:
    channels = (*CENTRED[:8], 2000, *CENTRED[9:])
    request = rc_request(channels, RcMapping())
    assert request is not None
    assert request.hazard
    assert not request.low_beam
