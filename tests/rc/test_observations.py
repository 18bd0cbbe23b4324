"""What the view counts as seen: ranges, rests, and the frames it leaves out."""

from __future__ import annotations

import itertools

from hypothesis import given
from hypothesis import strategies as st

from bywire.rc.observations import JOIN_RAW, REST_FRAMES, STEADY_SPREAD_RAW, Span
from tests.rc.frames import MAPPING, held, observed, ramp, with_channel

MODE = MAPPING.mode_switch.channel
STEERING = MAPPING.steering.channel


def test_a_held_value_is_a_rest_and_a_moving_one_is_not() -> None:
    raws = held(1000) + ramp(1000, 2000) + held(2000)
    channel = observed(with_channel(MODE, raws)).channels[MODE]
    assert channel.min_raw == 1000
    assert channel.max_raw == 2000
    assert [(place.low_raw, place.high_raw) for place in channel.places] == [
        (1000, 1000),
        (2000, 2000),
    ]


def test_a_value_held_for_fewer_frames_than_a_rest_is_no_place() -> None:
    raws = held(1000) + held(1500, REST_FRAMES - 1) + held(2000)
    places = observed(with_channel(MODE, raws)).channels[MODE].places
    assert [place.mean_raw for place in places] == [1000, 2000]


def test_the_run_going_on_now_counts_once_it_is_long_enough() -> None:
    short = observed(with_channel(MODE, held(1500, REST_FRAMES - 1))).channels[MODE]
    long = observed(with_channel(MODE, held(1500, REST_FRAMES))).channels[MODE]
    assert short.places == ()
    assert long.places == (Span(1500, 1500, REST_FRAMES, 1500 * REST_FRAMES),)


def test_two_visits_to_one_position_are_one_place_with_their_average() -> None:
    raws = held(1498) + held(2000) + held(1502) + held(2000)
    places = observed(with_channel(MODE, raws)).channels[MODE].places
    assert [(place.low_raw, place.high_raw, place.mean_raw) for place in places] == [
        (1498, 1502, 1500),
        (2000, 2000, 2000),
    ]


def test_a_jitter_within_the_steady_spread_is_one_rest_and_beyond_it_none() -> None:
    still = [1500, 1500 + STEADY_SPREAD_RAW] * REST_FRAMES
    shaking = [1500, 1500 + STEADY_SPREAD_RAW + 1] * REST_FRAMES
    assert len(observed(with_channel(STEERING, still)).channels[STEERING].places) == 1
    assert observed(with_channel(STEERING, shaking)).channels[STEERING].places == ()


def test_failsafe_frames_are_counted_and_left_out() -> None:
    failsafe = MAPPING.failsafe
    frames = list(with_channel(failsafe.channel, held(1500) + held(failsafe.below_raw - 50)))
    seen = observed(frames)
    assert seen.failsafe_frames == len(held(0))
    assert seen.frames == len(held(0))
    assert seen.channels[failsafe.channel].min_raw == 1500


def test_an_implausible_pulse_is_counted_on_its_channel_and_left_out() -> None:
    seen = observed(with_channel(STEERING, [1500, 2300, 700, 1600]))
    channel = seen.channels[STEERING]
    assert channel.implausible == 2
    assert (channel.min_raw, channel.max_raw) == (1500, 1600)


@given(
    st.lists(
        st.tuples(st.integers(800, 2200), st.integers(REST_FRAMES, 3 * REST_FRAMES)),
        min_size=1,
        max_size=8,
    )
)
def test_places_are_apart_sorted_and_cover_every_value_held_long_enough(
    script: list[tuple[int, int]],
) -> None:
    raws = [raw for value, frames in script for raw in held(value, frames)]
    places = observed(with_channel(MODE, raws)).channels[MODE].places
    for low, high in itertools.pairwise(places):
        assert high.low_raw - low.high_raw > JOIN_RAW
    for value, _frames in script:
        assert any(place.low_raw <= value <= place.high_raw for place in places)
    assert sum(place.frames for place in places) <= len(raws)
