"""The stop ramp: its line reaches zero inside the ramp, the brake stays in range, and from the
line's end (or standstill) the brake holds."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.ros2.settings import BridgeSettings
from bywire.ros2.stop_ramp import RAMP_SHARE, StopRamp

SETTINGS = BridgeSettings(stop_ramp_s=0.4)


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
def test_the_brake_is_in_range_and_holds_after_the_line(
    start_speed: float, elapsed: float, speed: float
) -> None:
    ramp = StopRamp(0.0, start_speed)
    brake = ramp.brake_norm(elapsed, speed, SETTINGS)
    assert 0.0 <= brake <= 1.0
    if elapsed >= RAMP_SHARE * SETTINGS.stop_ramp_s or speed <= SETTINGS.standstill_speed_mps:
        assert brake == SETTINGS.hold_brake


def test_above_the_line_it_brakes_harder() -> None:
    ramp = StopRamp(0.0, 1.0)
    on_line = ramp.brake_norm(0.1, ramp.reference_mps(0.1, SETTINGS), SETTINGS)
    above = ramp.brake_norm(0.1, ramp.reference_mps(0.1, SETTINGS) + 0.2, SETTINGS)
    assert above > on_line > 0.0
