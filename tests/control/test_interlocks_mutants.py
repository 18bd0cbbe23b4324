"""Interlocks at their exact edges: zero thresholds allowed, standstill speed inclusive, a
throttle above full scale never reaching the drive however long the slew has had."""

from __future__ import annotations

import pytest

from bywire.control.interlocks import InterlockConfig, InterlockState, interlock_step
from bywire.control.mux import Movement
from bywire.model import Gear

CONFIG = InterlockConfig()  # standstill 0.05 m/s


def test_zero_dwells_and_zero_standstill_speed_are_valid_settings() -> None:
    config = InterlockConfig(
        standstill_speed_mps=0.0, direction_dwell_s=0.0, unknown_speed_dwell_s=0.0
    )
    assert config.direction_dwell_s == 0.0


def test_a_negative_dwell_is_refused_with_a_message_saying_what_is_wrong() -> None:
    with pytest.raises(
        ValueError, match=r"^standstill speed, dwells and speed-check limits must be finite, >= 0$"
    ):
        InterlockConfig(direction_dwell_s=-0.1)


def test_a_bad_throttle_slew_is_refused_with_a_message_naming_it() -> None:
    with pytest.raises(ValueError, match=r"^throttle_slew_up_per_s must be finite and > 0$"):
        InterlockConfig(throttle_slew_up_per_s=0.0)


@pytest.mark.parametrize(
    ("gear", "speed_mps"),
    [
        (Gear.FORWARD, -0.03),  # rolling back, but slower than the standstill threshold
        (Gear.REVERSE, 0.03),
        (Gear.FORWARD, -0.05),  # exactly at the threshold: still standstill
        (Gear.REVERSE, 0.05),
    ],
)
def test_a_first_gear_is_granted_at_once_while_rolling_within_standstill(
    gear: Gear, speed_mps: float
) -> None:
    # No direction applied yet and throttle requested, so only the measured speed could hold it.
    requested = Movement(0.0, 0.5, 0.0, gear)
    _, applied, held = interlock_step(InterlockState(), requested, speed_mps, 0.0, CONFIG)
    assert not held
    assert applied.gear is gear


@pytest.mark.parametrize("gear", [Gear.FORWARD, Gear.REVERSE])
def test_a_first_gear_is_held_while_rolling_the_other_way_faster_than_standstill(
    gear: Gear,
) -> None:
    speed_mps = -0.06 if gear is Gear.FORWARD else 0.06
    requested = Movement(0.0, 0.5, 0.0, gear)
    _, applied, held = interlock_step(InterlockState(), requested, speed_mps, 0.0, CONFIG)
    assert held
    assert applied.gear is Gear.NEUTRAL
    assert applied.throttle_norm == 0.0


def test_a_throttle_above_full_scale_is_applied_as_full_scale_after_a_long_ramp() -> None:
    state = InterlockState(Gear.FORWARD, Gear.FORWARD, throttle_norm=1.0, updated_at=0.0)
    _, applied, _ = interlock_step(state, Movement(0.0, 1.5, 0.0, Gear.FORWARD), 0.0, 1.0, CONFIG)
    assert applied.throttle_norm == 1.0
