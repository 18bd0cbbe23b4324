"""What a transmitter was seen to send, channel by channel: a pure fold over IBUS frames.

For each of the 14 channels: the lowest and highest plausible pulse seen, and the places it
rested at. A *rest* is a run of at least `REST_FRAMES` frames in a row whose pulses stay within
`STEADY_SPREAD_RAW` µs of each other (a switch in a position, a stick let go or held still); a
stick or a switch on its way between two places changes by more than that within a run, so it
leaves no rest. Rests that come within `JOIN_RAW` µs of each other are one *place* (the same
switch position, visited twice). Frames the controller takes as the receiver's failsafe output
are counted and left out: they are not what the sticks send.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from bywire.control.rc_mapping import PLAUSIBLE_RAW, RcMapping, in_failsafe
from bywire.protocol import ibus

STEADY_SPREAD_RAW = 12  # µs: a receiver's jitter on a still stick is a few µs, a moving one more
REST_FRAMES = 13  # frames in a row (0.1 s at IBUS' 7.7 ms) that make a still value a rest
JOIN_RAW = 30  # µs: rests this close to each other are one place


@dataclass(frozen=True, slots=True)
class Span:
    """Pulses from `low_raw` to `high_raw` (µs, inclusive), seen in `frames` frames that add up
    to `total_raw`."""

    low_raw: int
    high_raw: int
    frames: int
    total_raw: int

    @classmethod
    def of(cls, raw: int) -> Span:
        """One frame's pulse."""
        return cls(raw, raw, 1, raw)

    @property
    def mean_raw(self) -> int:
        """The average pulse, rounded to the nearest µs."""
        return round(self.total_raw / self.frames)

    @property
    def spread_raw(self) -> int:
        """How far the span reaches from its average, either way (µs)."""
        return max(self.mean_raw - self.low_raw, self.high_raw - self.mean_raw)

    def near(self, other: Span, gap_raw: int) -> bool:
        """True when the two spans overlap or are at most `gap_raw` µs apart."""
        return other.low_raw - self.high_raw <= gap_raw and self.low_raw - other.high_raw <= gap_raw

    def joined(self, other: Span) -> Span:
        """One span covering both, their frames added."""
        return Span(
            min(self.low_raw, other.low_raw),
            max(self.high_raw, other.high_raw),
            self.frames + other.frames,
            self.total_raw + other.total_raw,
        )


@dataclass(frozen=True, slots=True)
class ChannelSeen:
    """One channel: its range, the run of still values it is in now, and the rests before."""

    min_raw: int | None = None
    max_raw: int | None = None
    run: Span | None = None
    rests: tuple[Span, ...] = ()
    implausible: int = 0

    @property
    def places(self) -> tuple[Span, ...]:
        """Where the channel rested, low to high, the run it is in now included once it is
        long enough to be a rest."""
        if self.run is not None and self.run.frames >= REST_FRAMES:
            return _with_rest(self.rests, self.run)
        return self.rests


@dataclass(frozen=True, slots=True)
class Observations:
    """Every channel of every intact frame seen since the start (or a reset)."""

    channels: tuple[ChannelSeen, ...] = (ChannelSeen(),) * ibus.CHANNEL_COUNT
    frames: int = 0
    failsafe_frames: int = 0


NOTHING_SEEN = Observations()


def observe(seen: Observations, channels: tuple[int, ...], mapping: RcMapping) -> Observations:
    """`seen` with one more intact frame; a failsafe frame (by the mapping's signature) is only
    counted."""
    if in_failsafe(channels, mapping):
        return replace(seen, failsafe_frames=seen.failsafe_frames + 1)
    return replace(
        seen,
        channels=tuple(
            _observe_channel(channel, raw)
            for channel, raw in zip(seen.channels, channels, strict=True)
        ),
        frames=seen.frames + 1,
    )


def _observe_channel(seen: ChannelSeen, raw: int) -> ChannelSeen:
    if raw not in PLAUSIBLE_RAW:
        return replace(seen, implausible=seen.implausible + 1)
    low = raw if seen.min_raw is None else min(seen.min_raw, raw)
    high = raw if seen.max_raw is None else max(seen.max_raw, raw)
    run, rests = seen.run, seen.rests
    if run is not None and max(run.high_raw, raw) - min(run.low_raw, raw) <= STEADY_SPREAD_RAW:
        run = run.joined(Span.of(raw))
    else:
        if run is not None and run.frames >= REST_FRAMES:
            rests = _with_rest(rests, run)
        run = Span.of(raw)
    return ChannelSeen(low, high, run, rests, seen.implausible)


def _with_rest(rests: tuple[Span, ...], rest: Span) -> tuple[Span, ...]:
    """The places with one more rest: joined with every place it comes near, low to high."""
    joined = rest
    apart: list[Span] = []
    for place in rests:
        if place.near(joined, JOIN_RAW):
            joined = joined.joined(place)
        else:
            apart.append(place)
    # A join can widen the rest enough to reach a place passed over before it.
    if any(place.near(joined, JOIN_RAW) for place in apart):
        return _with_rest(tuple(apart), joined)
    return tuple(sorted([*apart, joined], key=lambda span: span.low_raw))
