"""Driving motors: Table 2 levels, brake beats throttle, clamps, safe when disabled."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.drive import SAFE_DRIVE, DriveConfig, DriveOutputs, drive_outputs, unit_clamp
from bywire.control.mux import Movement
from bywire.model import Gear

CONFIG = DriveConfig()


def test_forward_throttle_scales_to_volts() -> None:
    outputs = drive_outputs(Movement(0.0, 0.5, 0.0, Gear.FORWARD), enabled=True, config=CONFIG)
    assert outputs == DriveOutputs(2.5, 0.0, enable=True, forward=True, reverse=False)


def test_reverse_sets_only_the_reverse_line() -> None:
    outputs = drive_outputs(Movement(0.0, 0.2, 0.0, Gear.REVERSE), enabled=True, config=CONFIG)
    assert (outputs.forward, outputs.reverse) == (False, True)
    assert outputs.throttle_volts == pytest.approx(1.0)


def test_brake_beats_throttle() -> None:
    outputs = drive_outputs(Movement(0.0, 1.0, 0.3, Gear.FORWARD), enabled=True, config=CONFIG)
    assert outputs.throttle_volts == 0.0
    assert outputs.regen_volts == pytest.approx(1.5)


def test_neutral_gives_no_throttle() -> None:
    outputs = drive_outputs(Movement(0.0, 1.0, 0.0, Gear.NEUTRAL), enabled=True, config=CONFIG)
    assert outputs.throttle_volts == 0.0
    assert not outputs.forward
    assert not outputs.reverse


def test_disabled_is_the_safe_state_whatever_the_set_point() -> None:
    assert (
        drive_outputs(Movement(1.0, 1.0, 0.0, Gear.FORWARD), enabled=False, config=CONFIG)
        == SAFE_DRIVE
    )
    assert DriveOutputs(0.0, 0.0, enable=False, forward=False, reverse=False) == SAFE_DRIVE


@pytest.mark.parametrize(
    ("throttle_norm", "brake_norm", "throttle_volts", "regen_volts"),
    [
        (2.0, 0.0, 5.0, 0.0),
        (-1.0, 0.0, 0.0, 0.0),
        (math.nan, 0.0, 0.0, 0.0),
        (0.5, math.nan, 0.0, 5.0),
    ],
)
def test_out_of_range_and_nan_clamp_towards_safe(
    throttle_norm: float, brake_norm: float, throttle_volts: float, regen_volts: float
) -> None:
    outputs = drive_outputs(Movement(0.0, throttle_norm, brake_norm, Gear.FORWARD), True, CONFIG)
    assert (outputs.throttle_volts, outputs.regen_volts) == (throttle_volts, regen_volts)


def test_configured_volt_limit_is_respected() -> None:
    config = DriveConfig(max_throttle_volts=3.3, max_regen_volts=2.0)
    outputs = drive_outputs(Movement(0.0, 1.0, 0.0, Gear.FORWARD), True, config)
    assert outputs.throttle_volts == pytest.approx(3.3)
    assert drive_outputs(Movement(0.0, 0.0, 1.0, Gear.FORWARD), True, config).regen_volts == 2.0


@given(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(list(Gear)),
    st.booleans(),
)
def test_volts_never_leave_their_limits(
    throttle: float, brake: float, gear: Gear, on: bool
) -> None:
    outputs = drive_outputs(Movement(0.0, throttle, brake, gear), on, CONFIG)
    assert 0.0 <= outputs.throttle_volts <= CONFIG.max_throttle_volts
    assert 0.0 <= outputs.regen_volts <= CONFIG.max_regen_volts
    assert not (outputs.throttle_volts > 0 and outputs.regen_volts > 0)
    assert not (outputs.forward and outputs.reverse)


# Tests added after mutation testing (docs/mutation.md). The command-unit clamp of the drive on
# its own (the volts clamp behind it hides its top end).


@pytest.mark.parametrize(
    ("value", "clamped"), [(1.5, 1.0), (math.inf, 1.0), (-0.5, 0.0), (0.25, 0.25)]
)
def test_unit_clamp_keeps_values_within_zero_and_one(value: float, clamped: float) -> None:
    assert unit_clamp(value, nan_value=0.0) == clamped
