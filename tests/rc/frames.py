"""IBUS channel tuples for the calibration tests: a transmitter at rest, and one channel's script
of held values and sweeps, as frames."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from bywire.control.rc_mapping import RcMapping
from bywire.hal.simulated.rc_transmitter import idle_channels
from bywire.rc.observations import REST_FRAMES, Observations, observe

MAPPING = RcMapping()
HOLD = REST_FRAMES + 7  # frames: a switch position held a moment


def with_channel(
    channel: int, raws: Iterable[int], mapping: RcMapping = MAPPING
) -> Iterator[tuple[int, ...]]:
    """Frames of a transmitter at rest whose `channel` carries `raws`, one a frame."""
    base = list(idle_channels(mapping))
    for raw in raws:
        base[channel] = raw
        yield tuple(base)


def held(raw: int, frames: int = HOLD) -> list[int]:
    return [raw] * frames


def ramp(start: int, end: int, step: int = 20) -> list[int]:
    """A stick moving from `start` to `end`, `step` µs a frame: too fast to leave a rest."""
    step = step if end >= start else -step
    return [*list(range(start, end, step)), end]


def observed(frames: Iterable[tuple[int, ...]], mapping: RcMapping = MAPPING) -> Observations:
    seen = Observations()
    for channels in frames:
        seen = observe(seen, channels, mapping)
    return seen
