"""How the calibration view looks: a row per IBUS channel and a status line, as rich Text.

A row: the channel (bywire's index from 0, and the transmitter's CH from 1), its function in the
robot file, the pulse now, the lowest and highest seen, what the controller reads in it with the
file's calibration, where it rested, and the suggestion for it.
"""

from __future__ import annotations

from collections.abc import Callable

from rich.table import Table
from rich.text import Text

from bywire.config.consistency import RC_FUNCTIONS
from bywire.control.rc_mapping import RcMapping, RcRequest, SwitchesHeld
from bywire.rc.ibus_reading import RcSession
from bywire.rc.suggestion import Refusal, Suggestion

COLUMNS = (
    "ch",
    "tx",
    "function",
    "now µs",
    "min µs",
    "max µs",
    "reads as",
    "rested at µs",
    "suggestion",
)
LABELS = {
    "steering": "steering",
    "throttle_brake": "throttle / brake",
    "mode_switch": "mode switch",
    "gear_switch": "gear switch",
    "low_beam_switch": "low beam",
    "hazard_switch": "hazard",
}
ERROR_STYLE = "bold red"
WARNING_STYLE = "bold yellow"
NONE = Text("-", style="dim")
STALE_S = 0.5  # no frame for this long: the status says so, in red


def functions(mapping: RcMapping) -> dict[int, str]:
    """The function of each used channel, by channel index (`steering`, `mode_switch`, …)."""
    return {getattr(mapping, name).channel: name for name in RC_FUNCTIONS}


def rows(session: RcSession, suggestion: Suggestion) -> list[tuple[Text, ...]]:
    """Every channel's cells, in `COLUMNS` order."""
    used = functions(session.mapping)
    failsafe = session.mapping.failsafe
    table: list[tuple[Text, ...]] = []
    for index, seen in enumerate(session.seen.channels):
        name = used.get(index)
        label = LABELS.get(name or "", "")
        if index == failsafe.channel:
            label = f"{label}, failsafe < {failsafe.below_raw}".lstrip(", ")
        now = None if session.channels is None else session.channels[index]
        places = " ".join(str(place.mean_raw) for place in seen.places)
        table.append(
            (
                Text(str(index), justify="right"),
                Text(f"CH{index + 1}"),
                Text(label) if label else NONE,
                _number(now),
                _number(seen.min_raw),
                _number(seen.max_raw),
                NONE if name is None else reads_as(name, session),
                Text(places) if places else NONE,
                NONE if name is None else _suggested(suggestion, name),
            )
        )
    return table


def reads_as(name: str, session: RcSession) -> Text:
    """What the controller reads in the latest frame for the function `name`."""
    if session.channels is None:
        return NONE
    if session.request is None:
        why = "failsafe" if session.in_failsafe else "implausible pulse"
        return Text(f"frame refused ({why}): STOP", style=ERROR_STYLE)
    return READERS[name](session.request, session.stage.held, session.mapping)


Reader = Callable[[RcRequest, SwitchesHeld, RcMapping], Text]


def _steering(request: RcRequest, _held: SwitchesHeld, _mapping: RcMapping) -> Text:
    return Text(f"{request.steering_norm:+.2f}")


def _pedal(request: RcRequest, _held: SwitchesHeld, _mapping: RcMapping) -> Text:
    if request.brake_norm > 0.0:
        return Text(f"brake {request.brake_norm:.2f}")
    return Text(f"throttle {request.throttle_norm:.2f}")


def _mode(_request: RcRequest, held: SwitchesHeld, mapping: RcMapping) -> Text:
    if held.mode is None:
        return Text("between positions: STOP", style=WARNING_STYLE)
    name = mapping.mode_positions[held.mode].name
    if held.mode_transit:  # between two driving positions: held for the debounce's frames
        return Text(f"{name} (in transit, held)", style=WARNING_STYLE)
    return Text(name)


def _gear(request: RcRequest, held: SwitchesHeld, mapping: RcMapping) -> Text:
    if held.gear is None:
        return Text("between positions: NEUTRAL", style=WARNING_STYLE)
    shown = mapping.gear_positions[held.gear]
    pending = "" if request.gear is shown else f" (debouncing; {request.gear.name} now)"
    return Text(f"{shown.name}{pending}")


def _light(name: str) -> Reader:
    def read(request: RcRequest, held: SwitchesHeld, _mapping: RcMapping) -> Text:
        if getattr(held, name) is None:
            return Text("between positions: off", style=WARNING_STYLE)
        return Text("on" if getattr(request, name) else "off")

    return read


READERS: dict[str, Reader] = {
    "steering": _steering,
    "throttle_brake": _pedal,
    "mode_switch": _mode,
    "gear_switch": _gear,
    "low_beam_switch": _light("low_beam"),
    "hazard_switch": _light("hazard"),
}


def _suggested(suggestion: Suggestion, name: str) -> Text:
    item = suggestion.item(name)
    return Text(item.brief(), style="dim" if isinstance(item, Refusal) else "bold green")


def _number(value: int | None) -> Text:
    return NONE if value is None else Text(str(value), justify="right")


def status(session: RcSession, source: str, problem: str | None, now_s: float) -> Text:
    """One line: the source, the frames, every error counter, how old the latest frame is."""
    stats = session.parser.stats
    text = Text(f"{source}: {stats.frames} frames, ")
    text.append(
        f"{stats.checksum_errors} checksum errors",
        style=ERROR_STYLE if stats.checksum_errors else "",
    )
    text.append(f", {stats.resyncs} resyncs, {stats.skipped_bytes} bytes skipped, ")
    failsafe = session.seen.failsafe_frames
    text.append(f"{failsafe} failsafe frames (left out)", style=WARNING_STYLE if failsafe else "")
    if session.last_frame_s is None:
        text.append("; no frame yet", style=ERROR_STYLE)
    elif (age_s := now_s - session.last_frame_s) > STALE_S:
        text.append(f"; no frame for {age_s:.1f} s", style=ERROR_STYLE)
    if problem:
        text.append(f"; {problem}", style=ERROR_STYLE)
    return text


def snapshot_table(session: RcSession, suggestion: Suggestion, title: Text) -> Table:
    """Every channel as one rich table (`bywire rc --once`/`--duration`)."""
    table = Table(*COLUMNS, title=title, title_justify="left", box=None, pad_edge=False)
    for cells in rows(session, suggestion):
        table.add_row(*cells)
    return table
