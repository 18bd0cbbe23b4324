"""The age gate: by arrival and by header stamp, at arrival and on every period after."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.ros2.setpoint import Refusal, Setpoint, Tally, admit, arrived, held, judge, usable
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


def _stream(
    lag_s: float | None, period_s: float, count: int, settings: BridgeSettings = SETTINGS
) -> Tally:
    """`count` commands every `period_s`, stamps `lag_s` old, and the periods between (20 ms)."""
    tally, stored = Tally(), None
    for index in range(count):
        arrival_s = index * period_s
        for tick in range(int(period_s / 0.02)):
            tally = held(tally, stored, arrival_s - period_s + tick * 0.02, settings)
        new = Setpoint(0.5, 0.0, arrival_s, lag_s)
        tally, refusal = arrived(tally, stored, new, settings)
        stored = new if refusal is None else stored
    return tally


def test_a_command_that_ages_past_its_stamp_before_the_next_one_is_refused_once() -> None:
    """Issue 41 finding 8, the rule alone: lag 0.17 s against 0.2 at 20 Hz."""
    settings = BridgeSettings(max_stamp_age_s=0.2)
    tally = _stream(0.17, 0.05, 40, settings)
    assert tally.count(Refusal.STAMP_OLD) == 39  # the last one is still held
    assert tally.total_refused == 39
    assert tally.accepted_at_s is None
    assert tally.refusing_since_s is not None
    assert tally.refusing_since_s < 0.1
    assert tally.last_refusal is Refusal.STAMP_OLD


def test_commands_replaced_while_usable_are_accepted_and_nothing_is_refused() -> None:
    tally = _stream(0.02, 0.05, 40)
    assert tally.total_refused == 0
    assert tally.accepted_at_s == pytest.approx(39 * 0.05)
    assert tally.refusing_since_s is None


def test_a_planner_slower_than_the_timeout_has_each_command_refused_as_late() -> None:
    tally = _stream(None, 0.3, 10)  # plain Twist (no stamp to age), cmd_timeout_s 0.2
    assert tally.count(Refusal.LATE) == 9
    assert tally.accepted_at_s is None


def test_refused_at_arrival_keeps_the_stored_one_pending_and_an_acceptance_ends_refusing() -> None:
    good = Setpoint(0.5, 0.0, 0.0, 0.0)
    tally, refusal = arrived(Tally(), None, good, SETTINGS)
    assert refusal is None
    assert tally.pending
    tally, refusal = arrived(tally, good, Setpoint(math.nan, 0.0, 0.05, 0.0), SETTINGS)
    assert refusal is Refusal.NOT_FINITE
    assert tally.pending  # the stored one still drives; its fate is not known yet
    assert tally.refusing_since_s == 0.05
    tally, _ = arrived(tally, good, Setpoint(0.5, 0.0, 0.1, 0.0), SETTINGS)
    assert tally.accepted_at_s == 0.1
    assert tally.refusing_since_s is None
    assert tally.total_refused == 1
    ahead = Setpoint(0.5, 0.0, 0.1, -0.08)  # its stamp falls behind: never "ahead" by ageing
    assert held(tally, ahead, 0.15, SETTINGS).total_refused == 1
    assert held(tally, ahead, 0.15 + 0.2, SETTINGS).total_refused == 1  # late: not by itself


def test_a_held_command_gone_late_while_every_newer_one_is_refused_is_counted_that_period() -> None:
    """`bywire verify --seed 1`, campaign 1903: the last good command drives on while the newer
    ones are refused at arrival (stamps 0.3 s old); the period it goes late the bridge stops,
    and that stop is counted then, once, not with the next refusal a planner's period later."""
    settings = BridgeSettings()  # defaults: lateness is judged before the stamp
    good = Setpoint(0.5, 0.0, 0.0, 0.0)
    tally, _ = arrived(Tally(), None, good, settings)
    tally, refusal = arrived(tally, good, Setpoint(0.5, 0.0, 0.1, 0.3), settings)
    assert refusal is Refusal.STAMP_OLD
    assert held(tally, good, 0.19, settings).total_refused == 1  # still usable
    late = held(tally, good, 0.21, settings)
    assert (late.total_refused, late.count(Refusal.LATE)) == (2, 1)
    assert held(late, good, 0.23, settings) == late  # once
    quiet, _ = arrived(Tally(), None, good, settings)  # nothing newer arrived: a planner that
    assert held(quiet, good, 0.21, settings) == quiet  # stopped, or one slower than the timeout
