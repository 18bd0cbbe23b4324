"""The command-unit clamp of the drive on its own (the volts clamp behind it hides its top end)."""

from __future__ import annotations

import math

import pytest

from bywire.control.drive import unit_clamp


@pytest.mark.parametrize(
    ("value", "clamped"), [(1.5, 1.0), (math.inf, 1.0), (-0.5, 0.0), (0.25, 0.25)]
)
def test_unit_clamp_keeps_values_within_zero_and_one(value: float, clamped: float) -> None:
    assert unit_clamp(value, nan_value=0.0) == clamped
