"""The stop ramp: its line reaches zero inside the ramp, the brake stays in range, past the line
it brakes fully until a trusted speed shows standstill, and without a trusted speed it brakes
fully for `blind_brake_s`, then holds."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.ros2.settings import BridgeSettings
from bywire.ros2.stop_ramp import (
    RAMP_SHARE,
    StopRamp,
    blind_brake_s,
    fastest_mps,
    stop_bound_s,
    strongest_decel_mps2,
)

SETTINGS = BridgeSettings(stop_ramp_s=0.4, hold_brake=0.1)


def test_the_line_falls_from_the_start_speed_to_zero_before_the_ramp_ends() -> None:
    ramp = StopRamp(started_s=2.0, from_speed_mps=1.0)
    assert ramp.reference_mps(2.0, SETTINGS) == 1.0
    assert ramp.reference_mps(2.0 + RAMP_SHARE * 0.4 / 2, SETTINGS) == pytest.approx(0.5)
    assert ramp.reference_mps(2.0 + RAMP_SHARE * 0.4, SETTINGS) == 0.0
    assert RAMP_SHARE < 1.0


@given(
    start_speed=st.floats(0.0, 5.0),
    elapsed=st.floats(0.0, 2.0),
    speed=st.floats(0.0, 5.0),
)
def test_the_brake_is_in_range_holds_only_at_standstill_and_is_full_past_the_line(
    start_speed: float, elapsed: float, speed: float
) -> None:
    ramp = StopRamp(0.0, start_speed)
    brake = ramp.brake_norm(elapsed, speed, SETTINGS)
    assert 0.0 <= brake <= 1.0
    standing = speed <= SETTINGS.standstill_speed_mps
    if standing:
        assert brake == SETTINGS.hold_brake
    elif elapsed >= RAMP_SHARE * SETTINGS.stop_ramp_s:
        assert brake == 1.0  # issue 41 finding 7: late, never let go


def test_the_brake_stays_full_past_the_line_until_standstill_is_shown() -> None:
    """Issue 41 finding 7: a 2 m/s ramp in 0.3 s that the brakes cannot follow."""
    settings = BridgeSettings(stop_ramp_s=0.3, hold_brake=0.1)
    ramp = StopRamp(0.0, 2.0)
    line_end_s = RAMP_SHARE * settings.stop_ramp_s
    assert ramp.brake_norm(line_end_s + 0.01, 0.64, settings) == 1.0
    assert ramp.brake_norm(5.0, settings.standstill_speed_mps * 1.01, settings) == 1.0
    assert ramp.brake_norm(5.0, settings.standstill_speed_mps, settings) == 0.1


def test_above_the_line_it_brakes_harder() -> None:
    ramp = StopRamp(0.0, 1.0)
    on_line = ramp.brake_norm(0.1, ramp.reference_mps(0.1, SETTINGS), SETTINGS)
    above = ramp.brake_norm(0.1, ramp.reference_mps(0.1, SETTINGS) + 0.2, SETTINGS)
    assert above > on_line > 0.0


def test_without_a_trusted_speed_it_brakes_fully_for_the_bound_then_holds() -> None:
    """Issue 41 finding 6: from the period the speed became unknown, however the ramp began."""
    for ramp in (StopRamp(0.0, None), StopRamp(0.0, 1.5)):
        blind = ramp.seen(0.3, None)
        assert blind.blind_since_s == 0.3
        assert blind.seen(0.5, None).blind_since_s == 0.3  # the first period counts
        bound_s = blind_brake_s(SETTINGS)
        assert blind.brake_norm(0.3, None, SETTINGS) == 1.0
        assert blind.brake_norm(0.3 + bound_s - 0.001, None, SETTINGS) == 1.0
        assert blind.brake_norm(0.3 + bound_s + 0.001, None, SETTINGS) == SETTINGS.hold_brake
        seen_again = blind.seen(2.0, 0.4)
        assert seen_again.blind_since_s is None
        assert seen_again.brake_norm(2.0, 0.4, SETTINGS) == 1.0  # rolling, past any line


def test_the_bounds_follow_the_brake_map_and_the_speeds() -> None:
    settings = BridgeSettings(stop_ramp_s=0.3)
    assert strongest_decel_mps2(settings) == settings.brake_decels_mps2[-1] == 5.65
    assert stop_bound_s(0.5, settings) == 0.3  # the brakes follow the line: the ramp's time
    assert stop_bound_s(2.0, settings) == pytest.approx(2.0 / 5.65 + 0.2 * 0.3)
    assert stop_bound_s(-2.0, settings) == stop_bound_s(2.0, settings)
    assert fastest_mps(settings) == 2.9  # the feed-forward map's top, above max_speed_mps
    assert fastest_mps(BridgeSettings(max_speed_mps=4.0)) == 4.0
    assert blind_brake_s(settings) == stop_bound_s(2.9, settings)
    weak = BridgeSettings(brake_decels_mps2=(0.1, 0.5), brake_norms=(0.0, 1.0))
    assert blind_brake_s(weak) == pytest.approx(2.9 / 0.5 + 0.2 * 0.4)
