"""A file-backed stand-in for the `gpiod` v2 module: no gpio-sim here, so chips are JSON files.

A chip is a file (`make_chip`) holding its label and line names; a request writes the levels of
its lines, the output values it was requested with, and whether it was released to
`<chip>.state.json`, atomically, so a test (or another process) reads them back at any time.
The backend under test (`bywire.hal.linux.gpio_gpiod`) uses only this part of the real API.
"""

from __future__ import annotations

import enum
import errno
import json
import os
import threading
import types
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

MARKER = "fake-gpiochip"
_SAVING = threading.Lock()  # one state snapshot at a time, whole


class Value(enum.Enum):
    INACTIVE = 0
    ACTIVE = 1


class Direction(enum.Enum):
    AS_IS = 1
    INPUT = 2
    OUTPUT = 3


class Bias(enum.Enum):
    AS_IS = 1
    DISABLED = 3
    PULL_UP = 4
    PULL_DOWN = 5


class Edge(enum.Enum):
    NONE = 1
    RISING = 2
    FALLING = 3
    BOTH = 4


class _EdgeType(enum.Enum):
    RISING_EDGE = 1
    FALLING_EDGE = 2


@dataclass(frozen=True)
class EdgeEvent:
    Type = _EdgeType
    event_type: _EdgeType
    line_offset: int


line = types.SimpleNamespace(Value=Value, Direction=Direction, Bias=Bias, Edge=Edge)
_LIVE: dict[str, LineRequest] = {}  # the newest request of each chip, by its path


class RequestReleasedError(Exception):
    """Raised when a released request is used, as gpiod's is."""


@dataclass(frozen=True)
class ChipInfo:
    name: str
    label: str
    num_lines: int


@dataclass
class LineSettings:
    direction: Direction = Direction.AS_IS
    output_value: Value = Value.INACTIVE
    bias: Bias = Bias.AS_IS
    edge_detection: Edge = Edge.NONE


def drive_input(chip: Path, name: str, high: bool) -> None:
    """Drive input line `name` of the chip's live request from outside (its edge recorded)."""
    _LIVE[str(chip)].drive(name, high)


def make_chip(
    path: Path, label: str, line_names: Sequence[str], *, interrupts: bool = True
) -> Path:
    """Create a chip file with these line names (offset = index). `interrupts` False: a chip
    whose lines have no interrupt, as user-mode Linux's gpio-sim: the kernel refuses edge
    detection on them (ENODEV)."""
    described = {MARKER: True, "label": label, "lines": list(line_names), "irq": interrupts}
    path.write_text(json.dumps(described))
    return path


def read_state(chip: Path) -> dict[str, Any]:
    """What the chip's request did: levels by line name, requested values, released."""
    state: dict[str, Any] = json.loads(Path(f"{chip}.state.json").read_text())
    return state


def is_gpiochip_device(path: str) -> bool:
    try:
        return bool(json.loads(Path(path).read_text()).get(MARKER))
    except (OSError, ValueError, AttributeError):
        return False


class Chip:
    def __init__(self, path: str) -> None:
        with open(path) as chip_file:  # raises FileNotFoundError, PermissionError like the real one
            description = json.load(chip_file)
        self.path = path
        self._label: str = description["label"]
        self._lines: list[str] = description["lines"]
        self._interrupts: bool = description.get("irq", True)

    def __enter__(self) -> Chip:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        pass

    def get_info(self) -> ChipInfo:
        return ChipInfo(Path(self.path).name, self._label, len(self._lines))

    def line_offset_from_id(self, id: str | int) -> int:
        if isinstance(id, int):
            if not 0 <= id < len(self._lines):
                raise ValueError("line offset of out range")
            return id
        if id not in self._lines:
            raise OSError(2, "No such file or directory")
        return self._lines.index(id)

    def request_lines(
        self, config: dict[Any, LineSettings | None], consumer: str | None = None
    ) -> LineRequest:
        values: dict[int, Value] = {}
        inputs: dict[int, LineSettings] = {}
        for key, settings in config.items():
            offsets: Iterable[Any] = key if isinstance(key, tuple) else (key,)
            for offset in offsets:
                number = self.line_offset_from_id(offset)
                if number in values:
                    raise ValueError(f"line must be configured exactly once - offset {number}")
                given = settings or LineSettings()
                if given.edge_detection is not Edge.NONE and not self._interrupts:
                    raise OSError(errno.ENODEV, "No such device")  # gpiolib-cdev: no IRQ
                if given.direction is Direction.INPUT:
                    inputs[number] = given
                    # an input reads what drives it: nothing but its pull, at first
                    values[number] = Value.ACTIVE if given.bias is Bias.PULL_UP else Value.INACTIVE
                else:
                    values[number] = given.output_value
        request = LineRequest(Path(self.path), self._lines, values, consumer, inputs)
        _LIVE[self.path] = request
        return request


class LineRequest:
    def __init__(
        self,
        chip: Path,
        names: list[str],
        values: dict[int, Value],
        consumer: str | None,
        inputs: dict[int, LineSettings] | None = None,
    ) -> None:
        self._chip, self._names, self._values = chip, names, dict(values)
        self._inputs = dict(inputs or {})
        self._edges: list[EdgeEvent] = []
        self._state: dict[str, Any] = {
            "consumer": consumer,
            "requested": {names[o]: v.value for o, v in values.items()},
            "levels": {names[o]: v.value for o, v in values.items()},
            "inputs": {
                names[o]: [s.bias.name, s.edge_detection.name] for o, s in self._inputs.items()
            },
            "released": False,
            "writes": 0,
        }
        self._save()

    def drive(self, name: str, high: bool) -> None:
        offset = self._names.index(name)
        value = Value.ACTIVE if high else Value.INACTIVE
        if value is not self._values[offset]:
            kind = _EdgeType.RISING_EDGE if high else _EdgeType.FALLING_EDGE
            if self._inputs[offset].edge_detection is not Edge.NONE:
                self._edges.append(EdgeEvent(kind, offset))
        self._values[offset] = value

    def wait_edge_events(self, timeout: float | None = None) -> bool:
        return bool(self._edges)

    def read_edge_events(self) -> list[EdgeEvent]:
        events, self._edges = self._edges, []
        return events

    @property
    def offsets(self) -> list[int]:
        return list(self._values)

    def set_value(self, offset: int, value: Value) -> None:
        if self._state["released"]:
            raise RequestReleasedError
        if offset in self._inputs:  # the kernel refuses to set an input (EPERM)
            raise OSError(1, "Operation not permitted")
        self._values[offset] = value
        self._state["levels"][self._names[offset]] = value.value
        self._state["writes"] += 1
        self._save()

    def set_values(self, values: dict[int, Value]) -> None:
        if self._state["released"]:
            raise RequestReleasedError
        if set(values) & set(self._inputs):  # the kernel refuses the whole set (EPERM)
            raise OSError(1, "Operation not permitted")
        for offset, value in values.items():
            self.set_value(offset, value)

    def get_value(self, offset: int) -> Value:
        if self._state["released"]:
            raise RequestReleasedError
        return self._values[offset]

    def release(self) -> None:
        self._state["released"] = True
        self._save()

    def _save(self) -> None:
        # A temporary file of the calling thread's own: the loop and the watchdog's thread may
        # set lines of one request at the same time, as libgpiod allows.
        target = Path(f"{self._chip}.state.json")
        temporary = target.with_suffix(f".{threading.get_ident()}.tmp")
        with _SAVING:
            temporary.write_text(json.dumps(self._state))
            os.replace(temporary, target)
