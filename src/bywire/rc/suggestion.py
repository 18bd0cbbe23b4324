"""From what was seen to the calibration to paste into the robot file: a pure function.

A stick (`[rc.steering]`, `[rc.throttle_brake]`): `min_raw` and `max_raw` are the lowest and
highest pulse seen, `center_raw` the average pulse of the place it rested at longest (where it
springs back to, or was held) among those at least `MIN_TRAVEL_RAW` µs from both ends: a stick
not moved that far to both ends of where it rests is refused.

A switch (`[rc.mode_switch]`, …): `positions_raw` are the average pulses of the places it rested
at, one per position; `band_raw` covers `BAND_SHARE` of the way to the nearest other position
(the defaults' 150 µs of 500) up to `MAX_BAND_RAW` (the default: a wider band only narrows the
"no position" gap, which is STOP for the mode switch), and at least every resting value seen
plus `REST_MARGIN_RAW`;
`hysteresis_raw` is a sixth of the band (the defaults' 25 of 150), less if the bands would
otherwise touch (at least one pulse between two positions lies beyond both bands widened by
their hysteresis). A switch seen resting at fewer places than it has positions (not moved through
all of them), or at more (a knob, or the wrong channel), or whose positions lie too close for
their scatter, is refused. What is suggested always passes the loader's own checks
(`config.sections.switch`, `config.consistency`): the bands, widened by the hysteresis, never
touch, so a value halfway between two positions reads as no position.

Channels, `reverse` and deadbands are not suggested: the robot file's stay.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import pairwise

from bywire.config.consistency import RC_AXES, RC_SWITCHES
from bywire.config.limits import SWITCH_BAND_RAW, SWITCH_HYSTERESIS_RAW
from bywire.control.rc_mapping import AxisCalibration, RcMapping, SwitchCalibration
from bywire.rc.observations import ChannelSeen, Observations, Span

MIN_TRAVEL_RAW = 200  # µs either way from the centre: a stick at 50 % travel gives 250
BAND_SHARE = 0.3  # of the gap to the nearest position, as the default 150 µs of 500
MAX_BAND_RAW = 150  # the default band; more only where the resting values scatter more
HYSTERESIS_PER_BAND = 6  # the default 25 µs of 150
MIN_HYSTERESIS_RAW = 2
REST_MARGIN_RAW = 10  # µs beyond the widest resting value seen


@dataclass(frozen=True, slots=True)
class AxisSuggestion:
    """A stick's end points and centre (µs)."""

    name: str
    min_raw: int
    center_raw: int
    max_raw: int

    def apply(self, axis: AxisCalibration) -> AxisCalibration:
        return replace(axis, min_raw=self.min_raw, center_raw=self.center_raw, max_raw=self.max_raw)

    def brief(self) -> str:
        return f"min {self.min_raw} center {self.center_raw} max {self.max_raw}"


@dataclass(frozen=True, slots=True)
class SwitchSuggestion:
    """A switch's nominal pulses (low to high), band and hysteresis (µs)."""

    name: str
    positions_raw: tuple[int, ...]
    band_raw: int
    hysteresis_raw: int

    def apply(self, switch: SwitchCalibration) -> SwitchCalibration:
        return replace(
            switch,
            positions_raw=self.positions_raw,
            band_raw=self.band_raw,
            hysteresis_raw=self.hysteresis_raw,
        )

    def brief(self) -> str:
        positions = "/".join(map(str, self.positions_raw))
        return f"{positions} ±{self.band_raw} hyst {self.hysteresis_raw}"


@dataclass(frozen=True, slots=True)
class Refusal:
    """Why a stick or a switch gets no suggestion: `reason` says it and what to do about it in
    one line, `short` in a few words (a table cell)."""

    name: str
    short: str
    reason: str

    def brief(self) -> str:
        return f"none: {self.short}"


Item = AxisSuggestion | SwitchSuggestion | Refusal


@dataclass(frozen=True, slots=True)
class Suggestion:
    """One item per stick and switch of the mapping, in `RC_AXES`, `RC_SWITCHES` order."""

    items: tuple[Item, ...]

    @property
    def suggested(self) -> tuple[AxisSuggestion | SwitchSuggestion, ...]:
        return tuple(item for item in self.items if not isinstance(item, Refusal))

    @property
    def refusals(self) -> tuple[Refusal, ...]:
        return tuple(item for item in self.items if isinstance(item, Refusal))

    def item(self, name: str) -> Item:
        """The item of the stick or switch `name` (`steering`, `mode_switch`, …)."""
        return next(item for item in self.items if item.name == name)

    def mapping(self, base: RcMapping) -> RcMapping:
        """`base` with every suggested calibration in place (refused ones as they were)."""
        changes: dict[str, object] = {}
        for item in self.suggested:
            changes[item.name] = item.apply(getattr(base, item.name))
        return replace(base, **changes)  # type: ignore[arg-type]


def suggest(seen: Observations, mapping: RcMapping) -> Suggestion:
    """The calibration `seen` supports for each stick and switch of `mapping`."""
    axes = tuple(
        suggest_axis(name, seen.channels[getattr(mapping, name).channel]) for name in RC_AXES
    )
    switches = tuple(
        suggest_switch(name, seen.channels[switch.channel], len(switch.positions_raw))
        for name in RC_SWITCHES
        for switch in (getattr(mapping, name),)
    )
    return Suggestion((*axes, *switches))


def suggest_axis(name: str, seen: ChannelSeen) -> AxisSuggestion | Refusal:
    """A stick's `min/center/max` from its range and its resting places."""
    if seen.min_raw is None or seen.max_raw is None:
        return Refusal(name, "no frames", "no frames seen on its channel")
    low, high, places = seen.min_raw, seen.max_raw, seen.places
    if not places:
        return Refusal(
            name, "never still", "never held still: let the stick rest at its centre a moment"
        )
    inside = [
        place
        for place in places
        if min(place.mean_raw - low, high - place.mean_raw) >= MIN_TRAVEL_RAW
    ]
    centre = max(inside or places, key=lambda place: place.frames).mean_raw
    down, up = centre - low, high - centre
    if not inside:
        return Refusal(
            name,
            "not at both ends",
            f"moved {down} µs below and {up} µs above where it rests ({centre} µs): move the"
            f" stick to both ends (at least {MIN_TRAVEL_RAW} µs each way) and let it go",
        )
    return AxisSuggestion(name, low, centre, high)


def suggest_switch(name: str, seen: ChannelSeen, count: int) -> SwitchSuggestion | Refusal:
    """A switch's positions, band and hysteresis from the `count` places it rested at."""
    places = seen.places
    if len(places) < count:
        where = f" ({_pulses(places)} µs)" if places else ""
        return Refusal(
            name,
            f"{len(places)} of {count} positions",
            f"rested at {len(places)} of its {count} positions{where}: move it through every"
            " position, holding each a moment",
        )
    if len(places) > count:
        return Refusal(
            name,
            f"{len(places)} places",
            f"rested at {len(places)} places ({_pulses(places)} µs), more than its {count}"
            " positions: a knob or a stick on this channel? hold the switch at its positions",
        )
    positions = tuple(place.mean_raw for place in places)
    gap = min(b - a for a, b in pairwise(positions))
    spread = max(place.spread_raw for place in places)
    proportional = min(round(BAND_SHARE * gap), MAX_BAND_RAW)
    band = max(proportional, spread + REST_MARGIN_RAW, SWITCH_BAND_RAW.start)
    hysteresis = max(round(band / HYSTERESIS_PER_BAND), MIN_HYSTERESIS_RAW)
    # At least one pulse between two positions beyond both widened bands: a switch moving from
    # one to the other passes through no position even with a position held.
    hysteresis = min(hysteresis, SWITCH_HYSTERESIS_RAW[-1], (gap - 2) // 2 - band)
    if band > SWITCH_BAND_RAW[-1] or hysteresis < SWITCH_HYSTERESIS_RAW.start:
        return Refusal(
            name,
            "scatter too wide",
            f"positions {_pulses(places)} µs scatter ±{spread} µs, too much for bands that"
            f" leave a gap between positions {gap} µs apart: is it a switch?",
        )
    return SwitchSuggestion(name, positions, band, hysteresis)


def _pulses(places: tuple[Span, ...]) -> str:
    return ", ".join(str(place.mean_raw) for place in places)
