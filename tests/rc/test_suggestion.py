"""The suggestion: what it gives for a transmitter moved through everything, what it refuses,
and, for any transmitter, that what it gives decodes every resting value as its position, no
value between positions as any, and passes the loader's own checks."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from bywire.config import RobotConfig, parse_config
from bywire.control.rc_mapping import RcMapping, axis_norm, switch_position
from bywire.rc.observations import JOIN_RAW, REST_FRAMES
from bywire.rc.snippet import snippet_text, suggested_config
from bywire.rc.suggestion import (
    MIN_TRAVEL_RAW,
    AxisSuggestion,
    Refusal,
    Suggestion,
    SwitchSuggestion,
    suggest,
)
from tests.rc.frames import MAPPING, held, observed, ramp, with_channel

SWITCHES = ("mode_switch", "gear_switch", "low_beam_switch", "hazard_switch")


def _channel(name: str) -> int:
    channel: int = getattr(MAPPING, name).channel
    return channel


def _switch_frames(name: str, raws: list[int]) -> Iterator[tuple[int, ...]]:
    return with_channel(_channel(name), raws)


def _suggestion(frames: Iterator[tuple[int, ...]], mapping: RcMapping = MAPPING) -> Suggestion:
    return suggest(observed(frames, mapping), mapping)


def _loaded(suggestion: Suggestion) -> RcMapping:
    """The snippet, read by the loader as a robot file of its own."""
    text = snippet_text(RobotConfig(), suggestion, origin="test", seen_on="test")
    return parse_config(text, "snippet").rc.mapping


def test_a_standard_transmitter_moved_through_everything_gets_the_defaults() -> None:
    frames = itertools.chain(
        with_channel(0, held(1500) + ramp(1500, 1000) + ramp(1000, 2000) + ramp(2000, 1500)),
        with_channel(1, held(1500) + ramp(1500, 1000) + ramp(1000, 2000) + ramp(2000, 1500)),
        with_channel(1, held(1500)),
        _switch_frames("mode_switch", held(1000) + held(1500) + held(2000)),
        _switch_frames("gear_switch", held(1000) + held(1500) + held(2000)),
        _switch_frames("low_beam_switch", held(1000) + held(2000)),
        _switch_frames("hazard_switch", held(1000) + held(2000)),
    )
    suggestion = _suggestion(frames)
    assert suggestion.refusals == ()
    assert suggestion.mapping(MAPPING) == RcMapping()
    assert _loaded(suggestion) == RcMapping()


def test_a_mode_switch_at_half_travel_gets_bands_that_read_its_low_position_as_stop() -> None:
    """Finding 3 of issue 30: 1250 µs is STOP on such a transmitter; the default bands read it
    as between positions (STOP too, but RC and CAN are then out of reach at 1500 and 1750 µs
    only by luck); the suggestion reads each position as itself and 1375 µs as none."""
    suggestion = _suggestion(_switch_frames("mode_switch", held(1250) + held(1500) + held(1750)))
    item = suggestion.item("mode_switch")
    assert item == SwitchSuggestion("mode_switch", (1250, 1500, 1750), 75, 12)
    mode = _loaded(suggestion).mode_switch
    assert [switch_position(raw, mode) for raw in (1250, 1500, 1750)] == [0, 1, 2]
    assert switch_position(1375, mode, held=0) is None
    assert switch_position(1250, MAPPING.mode_switch) is None  # the file's bands before


@pytest.mark.parametrize(
    ("raws", "short"),
    [
        (held(1000) + held(1500), "2 of 3 positions"),
        (held(1000) + held(1250) + held(1500) + held(2000), "4 places"),
        (held(1000) + held(1500, REST_FRAMES - 1) + held(2000), "2 of 3 positions"),
        ([1000, 1500, 2000] * 20, "0 of 3 positions"),
    ],
    ids=["not-every-position", "a-knob", "middle-passed-through", "never-held"],
)
def test_a_switch_not_moved_through_its_positions_alone_is_refused(
    raws: list[int], short: str
) -> None:
    item = _suggestion(_switch_frames("mode_switch", raws)).item("mode_switch")
    assert isinstance(item, Refusal)
    assert item.short == short
    assert "\n" not in item.reason


def test_switch_positions_too_close_for_their_scatter_are_refused() -> None:
    """A place that wandered over 100 µs (rests each within JOIN_RAW of the next), and another
    just beyond JOIN_RAW of it: no band can hold the first and leave a gap before the second."""
    wandering = [raw for start in range(1000, 1101, 25) for raw in held(start)]
    raws = wandering + held(1100 + JOIN_RAW + 1) + held(1500)
    item = _suggestion(_switch_frames("mode_switch", raws)).item("mode_switch")
    assert isinstance(item, Refusal)
    assert item.short == "scatter too wide"


def test_between_two_close_positions_a_pulse_reads_as_none_even_with_a_position_held() -> None:
    """Positions 45 µs apart: bands of ±20 µs and ±2 µs of hysteresis would end at 958 and
    959 µs, passing from one held position to the next without a pulse of no position (the
    loader accepts that); the suggestion leaves 958 µs to no position."""
    raws = held(800) + held(936) + held(981)
    suggestion = _suggestion(_switch_frames("mode_switch", raws))
    assert suggestion.item("mode_switch") == SwitchSuggestion("mode_switch", (800, 936, 981), 20, 1)
    mode = _loaded(suggestion).mode_switch
    assert [switch_position(958, mode, held) for held in (None, 0, 1, 2)] == [None] * 4


@pytest.mark.parametrize(
    ("raws", "short"),
    [
        (held(1500) + ramp(1500, 1000) + ramp(1000, 1500), "not at both ends"),
        (held(1500) + ramp(1500, 2000) + ramp(2000, 1400), "not at both ends"),
        (ramp(1500, 1000) + ramp(1000, 2000), "never still"),
        (held(1500) + ramp(1500, 1000) + ramp(1000, 1500 + MIN_TRAVEL_RAW - 1), "not at both ends"),
    ],
    ids=["one-end", "other-end", "never-still", "just-short"],
)
def test_a_stick_not_moved_to_both_ends_is_refused(raws: list[int], short: str) -> None:
    item = _suggestion(with_channel(0, raws)).item("steering")
    assert isinstance(item, Refusal)
    assert item.short == short


def test_a_stick_held_at_an_end_longer_than_at_its_centre_still_gets_its_centre() -> None:
    raws = held(1500) + ramp(1500, 1000) + held(1000, 5 * REST_FRAMES) + ramp(1000, 2000)
    item = _suggestion(with_channel(0, raws)).item("steering")
    assert item == AxisSuggestion("steering", 1000, 1500, 2000)


def test_the_throttle_sticks_failsafe_frames_do_not_widen_its_range() -> None:
    below = MAPPING.failsafe.below_raw
    raws = held(1500) + ramp(1500, below) + held(below - 50) + ramp(below, 2000) + held(1500)
    item = _suggestion(with_channel(MAPPING.failsafe.channel, raws)).item("throttle_brake")
    assert item == AxisSuggestion("throttle_brake", below, 1500, 2000)


def test_refusals_are_comments_and_leave_the_files_own_table() -> None:
    suggestion = _suggestion(_switch_frames("mode_switch", held(1250) + held(1500)))
    text = snippet_text(RobotConfig(), suggestion, origin="robot.toml", seen_on="a pty")
    assert "[rc.mode_switch]" not in text
    assert "# rc.mode_switch: not suggested: rested at 2 of its 3 positions" in text
    assert parse_config(text, "snippet") == RobotConfig()


# --- properties --------------------------------------------------------------------------------


Visit = tuple[int, list[int]]  # a position's index and the pulses of the frames it was held


@st.composite
def switch_sessions(draw: st.DrawFn) -> tuple[str, list[int], list[Visit]]:
    """A switch moved through all its positions in any order, each held a moment with a jitter
    of up to ±5 µs: the switch's name, its true positions, and the visits."""
    name = draw(st.sampled_from(SWITCHES))
    count = len(getattr(MAPPING, name).positions_raw)
    first = draw(st.integers(820, 1400))
    gaps = draw(st.lists(st.integers(80, 600), min_size=count - 1, max_size=count - 1))
    positions = list(itertools.accumulate([first, *gaps]))
    assume(positions[-1] <= 2180)
    jitter = draw(st.integers(0, 5))
    order = list(draw(st.permutations(range(count))))
    order += draw(st.lists(st.integers(0, count - 1), max_size=3))
    visits: list[Visit] = []
    for index in order:
        frames = draw(st.integers(REST_FRAMES, 3 * REST_FRAMES))
        offsets = draw(st.lists(st.integers(-jitter, jitter), min_size=frames, max_size=frames))
        visits.append((index, [positions[index] + offset for offset in offsets]))
    return name, positions, visits


@given(switch_sessions(), st.booleans())
def test_a_switch_moved_through_every_position_gets_bands_that_hold_what_was_seen(
    session: tuple[str, list[int], list[Visit]], transit: bool
) -> None:
    """`transit`: a frame caught halfway between two positions as the switch moves."""
    name, positions, visits = session
    raws: list[int] = []
    for _index, values in visits:
        if transit and raws:
            raws.append((raws[-1] + values[0]) // 2)
        raws += values
    suggestion = _suggestion(_switch_frames(name, raws))
    item = suggestion.item(name)
    assert isinstance(item, SwitchSuggestion), item
    assert all(abs(a - b) <= 5 for a, b in zip(item.positions_raw, positions, strict=True))
    switch = getattr(_loaded(suggestion), name)
    assert switch.positions_raw == item.positions_raw
    for index, values in visits:
        for held_before in (None, *range(len(positions))):
            assert {switch_position(raw, switch, held_before) for raw in values} == {index}


@given(
    st.sampled_from(SWITCHES),
    st.lists(
        st.tuples(st.integers(800, 2200), st.integers(1, 3 * REST_FRAMES)), min_size=1, max_size=12
    ),
)
def test_whatever_a_switch_channel_shows_a_suggestion_keeps_positions_apart_and_loads(
    name: str, script: list[tuple[int, int]]
) -> None:
    raws = [raw for value, frames in script for raw in held(value, frames)]
    seen = observed(_switch_frames(name, raws))
    suggestion = suggest(seen, MAPPING)
    item = suggestion.item(name)
    places = seen.channels[_channel(name)].places
    count = len(getattr(MAPPING, name).positions_raw)
    if len(places) != count:
        assert isinstance(item, Refusal)
        return
    if isinstance(item, Refusal):
        assert item.short == "scatter too wide"
        return
    switch = getattr(_loaded(suggestion), name)
    reach = switch.band_raw + switch.hysteresis_raw
    for low, high in itertools.pairwise(switch.positions_raw):
        assert low + reach < high - reach  # the bands, held by the hysteresis, never touch
        middle = (low + high) // 2
        for held_before in (None, *range(count)):
            assert switch_position(middle, switch, held_before) is None
    for index, place in enumerate(places):
        for raw in (place.low_raw, place.high_raw, place.mean_raw):
            assert switch_position(raw, switch) == index


@given(
    st.sampled_from(SWITCHES),
    st.integers(850, 1500),
    st.lists(st.integers(JOIN_RAW + 1, 150), min_size=1, max_size=2),
    st.lists(st.integers(0, 12), min_size=3, max_size=3),
)
def test_positions_close_together_get_bands_that_do_not_touch_or_a_refusal(
    name: str, first: int, gaps: list[int], scatters: list[int]
) -> None:
    """Positions a little more than JOIN_RAW apart, each resting with its own scatter: the
    hysteresis must shrink to keep the bands apart, or the switch is refused."""
    count = len(getattr(MAPPING, name).positions_raw)
    assume(len(gaps) == count - 1)
    positions = list(itertools.accumulate([first, *gaps]))
    raws: list[int] = []
    for position, scatter in zip(positions, scatters, strict=False):
        raws += [position, position + scatter] * REST_FRAMES
    suggestion = _suggestion(_switch_frames(name, raws))
    item = suggestion.item(name)
    if isinstance(item, Refusal):
        assert item.short == "scatter too wide" or item.short.endswith(f"of {count} positions")
        return
    switch = getattr(_loaded(suggestion), name)  # the loader's checks pass
    reach = switch.band_raw + switch.hysteresis_raw
    for low, high in itertools.pairwise(switch.positions_raw):
        assert low + reach < high - reach
    for position, scatter in zip(positions, scatters, strict=False):
        assert switch_position(position, switch) == switch_position(position + scatter, switch)
        assert switch_position(position, switch) is not None


@st.composite
def stick_sessions(draw: st.DrawFn) -> tuple[int, list[int]]:
    """A stick let go at its centre, moved to both ends and back (±5 µs of jitter at rest)."""
    jitter = draw(st.integers(0, 5))
    travel = MIN_TRAVEL_RAW + jitter  # from wherever the jitter puts the centre's average
    centre = draw(st.integers(800 + travel, 2200 - travel))
    low = centre - draw(st.integers(travel, centre - 800))
    high = centre + draw(st.integers(travel, 2200 - centre))
    rest = [centre + draw(st.integers(-jitter, jitter)) for _ in range(REST_FRAMES + 5)]
    order = draw(st.sampled_from([(low, high), (high, low)]))
    raws = rest + ramp(centre, order[0]) + ramp(order[0], order[1]) + ramp(order[1], centre)
    return centre, raws + rest


@given(stick_sessions())
def test_a_stick_moved_to_both_ends_gets_its_range_and_centre_and_loads(
    session: tuple[int, list[int]],
) -> None:
    centre, raws = session
    suggestion = _suggestion(with_channel(0, raws))
    item = suggestion.item("steering")
    assert isinstance(item, AxisSuggestion), item
    assert (item.min_raw, item.max_raw) == (min(raws), max(raws))
    assert abs(item.center_raw - centre) <= 5
    axis = _loaded(suggestion).steering
    assert axis_norm(item.min_raw, axis) == -1.0
    assert axis_norm(item.max_raw, axis) == 1.0
    assert axis_norm(item.center_raw, axis) == 0.0


def test_the_suggested_config_is_the_robot_file_with_the_suggested_rc_section() -> None:
    suggestion = _suggestion(_switch_frames("gear_switch", held(1100) + held(1500) + held(1900)))
    config = suggested_config(RobotConfig(name="albert"), suggestion)
    assert config.name == "albert"
    assert config.rc.mapping.gear_switch.positions_raw == (1100, 1500, 1900)
    assert config.rc.mapping.mode_switch == MAPPING.mode_switch
