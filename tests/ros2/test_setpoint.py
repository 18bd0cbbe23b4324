"""The age gate: by arrival and by header stamp, at arrival and on every period after."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.ros2.setpoint import Refusal, Setpoint, admit, judge, usable
from bywire.ros2.settings import BridgeSettings

SETTINGS = BridgeSettings(cmd_timeout_s=0.2, max_stamp_age_s=0.1)


@pytest.mark.parametrize(
    ("stamp_age_s", "held_s", "verdict"),
    [
        (0.0, 0.0, None),
        (0.1, 0.0, None),
        (0.11, 0.0, Refusal.STAMP_OLD),
        (0.05, 0.06, Refusal.STAMP_OLD),  # it aged while held
        (-0.1, 0.0, None),
        (-0.11, 0.0, Refusal.STAMP_AHEAD),
        (None, 0.2, None),
        (None, 0.21, Refusal.LATE),
        (-1.0, 0.21, Refusal.LATE),
        (1e9, 0.0, Refusal.STAMP_OLD),  # a zero stamp: "the epoch" is very old
    ],
)
def test_judge(stamp_age_s: float | None, held_s: float, verdict: Refusal | None) -> None:
    setpoint = Setpoint(0.5, 0.0, arrived_s=10.0, stamp_age_s=stamp_age_s)
    assert judge(setpoint, 10.0 + held_s, SETTINGS) is verdict


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_value_that_is_not_a_number_is_refused(bad: float) -> None:
    assert admit(Setpoint(bad, 0.0, 0.0, 0.0), SETTINGS) is Refusal.NOT_FINITE
    assert admit(Setpoint(0.5, bad, 0.0, 0.0), SETTINGS) is Refusal.NOT_FINITE
    assert admit(Setpoint(0.5, None, 0.0, 0.0), SETTINGS) is None


@given(
    stamp_age=st.none() | st.floats(-1.0, 1.0),
    held=st.floats(0.0, 1.0),
)
def test_usable_means_both_ages_within_their_limits(stamp_age: float | None, held: float) -> None:
    setpoint = Setpoint(0.5, 0.0, 0.0, stamp_age)
    by_arrival, by_stamp = setpoint.ages_s(held)
    within = by_arrival <= SETTINGS.cmd_timeout_s and (
        by_stamp is None or abs(by_stamp) <= SETTINGS.max_stamp_age_s
    )
    assert usable(setpoint, held, SETTINGS) is within


def test_nothing_is_not_usable() -> None:
    assert not usable(None, 0.0, SETTINGS)
