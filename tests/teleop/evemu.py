"""evemu-record's text format, read into evdev's own types: the axes' AbsInfo and InputEvents."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from evdev import AbsInfo, InputEvent

DATA = Path(__file__).parents[1] / "data" / "gamepad"


@dataclass(frozen=True)
class Recording:
    """A device's name, its axes (code -> AbsInfo) and its events, in file order."""

    name: str
    axes: dict[int, AbsInfo]
    events: list[InputEvent]


def read(path: Path) -> Recording:
    """Parse ``N:``, ``A:`` (code min max fuzz flat resolution) and ``E:`` lines; skip others."""
    name, axes, events = "", {}, []
    for line in path.read_text(encoding="utf-8").splitlines():
        fields = line.split("#", 1)[0].split()
        if line.startswith("N:"):
            name = line[2:].strip()
        elif fields[:1] == ["A:"]:
            code, low, high, fuzz, flat, resolution = fields[1:7]
            axes[int(code, 16)] = AbsInfo(
                0, int(low), int(high), int(fuzz), int(flat), int(resolution)
            )
        elif fields[:1] == ["E:"]:
            sec, usec = fields[1].split(".")
            kind, event_code, value = int(fields[2], 16), int(fields[3], 16), int(fields[4])
            events.append(InputEvent(int(sec), int(usec), kind, event_code, value))
    return Recording(name, axes, events)
