"""Drawing robot files across the loader's whole legal space (`bywire verify --draw-robots N`).

The ranges come from the loader itself: `config.loader.read_schema` records every key it reads
from the base file, with the Interval, range or choices it checks the key against. A drawn file
moves every key that is not a hardware pick (`picks_hardware`) to a low end, a high end (just
inside when the end is open), the base file's value, or a random interior value, each key on its
own, so a file combines many edges at once. Several keys must agree (min < centre < max, the
deadline rows of `config/deadlines.py`, …): a drawn file the loader refuses is repaired toward
the base file, one refusal at a time, by putting back the base value of a drawn key the refusal
names (or, when it names none that was drawn, of one drawn key of its section), until it loads.
Every refusal is counted by its rule; that is information too: which rules bite the legal space
hardest.

File `index` of seed `seed` is drawn from its own random source, so the same seed gives the same
files whatever else runs.
"""

from __future__ import annotations

import builtins
import math
import random
import re
import tomllib
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field

from bywire.config.consistency import check_consistency
from bywire.config.loader import build_robot, read_schema
from bywire.config.reader import Interval, KeyRead, Problems, show, show_key
from bywire.config.tree import RobotConfig

EDGE_WEIGHTS = {"low": 3.0, "high": 3.0, "base": 2.0, "interior": 2.0}
"""How often each kind of value is drawn for a key: the ends most of all."""
INSIDE_FRACTION = 1e-4
"""An open end is drawn just inside it, by this fraction of the range."""
MAX_HALVINGS = 6
"""A refused drawn value is moved half way back to the base value at most this often, then put
back: the edge of what the other keys allow is found to 1/64 of the way."""
UNBOUNDED_FACTOR = 10.0
"""A range without a high end is drawn up to this many times the base value."""

HARDWARE_SECTIONS = ("can", "realtime", "telemetry")
"""Sections that pick the bus, the process or the feed, not how the robot behaves."""
HARDWARE_KEYS = re.compile(r"(.*_)?channel|i2c_bus|address|enabled")
"""Keys that pick wiring (an IBUS, PWM or DAC channel, an I2C bus or address) or need files
beside the robot's (security.enabled needs a key file)."""
DECLARATIONS = frozenset({("timeouts", "stop_response_s")})
"""Keys that declare the file is no robot's: a test bench's longer share of the stop promise
(`config/deadlines.py` `StopPromise`), which `bywire verify` still judges at the requirement's.
Drawing one would only find what the file already says; they stay as the base file has them."""


def picks_hardware(read: KeyRead) -> bool:
    """A key that stays as the base file has it: a string (backend, interface, device path, pin,
    process setting), a wiring number, a key of a section that picks the bus or the process, a
    declaration that the file is a test bench's, or one axis of a measured calibration map
    (`[vehicle] flat_speeds_mps`: its two axes must keep their length together)."""
    kept_kinds = ("text", "numbers")
    if read.kind in kept_kinds or read.parts[0] in HARDWARE_SECTIONS or read.parts in DECLARATIONS:
        return True
    return HARDWARE_KEYS.fullmatch(read.parts[-1]) is not None


def dotted(parts: tuple[str, ...]) -> str:
    """A key's name as the loader's messages write it."""
    return ".".join(show_key(part) for part in parts)


@dataclass(frozen=True, slots=True)
class Schema:
    """The base file, as TOML data, and every key the loader reads from it, split into those a
    drawing moves and those it keeps."""

    base_text: str
    base: Mapping[str, object]
    keys: tuple[KeyRead, ...]  # drawn
    kept: tuple[KeyRead, ...]  # hardware picks, as the base file has them

    @classmethod
    def of(cls, base_text: str, origin: str = "<base robot file>") -> Schema:
        reads = read_schema(base_text, origin)
        unique = {read.parts: read for read in reads}  # a key read twice counts once
        drawn = tuple(read for read in unique.values() if not picks_hardware(read))
        kept = tuple(read for read in unique.values() if picks_hardware(read))
        return cls(base_text, tomllib.loads(base_text), drawn, kept)


# --- one key's values ---------------------------------------------------------------------------


def _number_edges(allowed: Interval, base: float) -> dict[str, float]:
    span_high = allowed.high if math.isfinite(allowed.high) else max(base, 1.0) * UNBOUNDED_FACTOR
    inside = (span_high - allowed.low) * INSIDE_FRACTION
    low = allowed.low + inside if allowed.low_open else allowed.low
    high = span_high - inside if allowed.high_open else span_high
    return {"low": low, "high": high}


def _interior(allowed: Interval, base: float, rng: random.Random) -> float:
    edges = _number_edges(allowed, base)
    span = edges["high"] - edges["low"]
    value = edges["low"] + span * rng.random()
    digits = max(3, 3 - math.floor(math.log10(span))) if span > 0 else 6
    rounded = round(value, digits)
    return rounded if rounded in allowed else value


def draw_value(read: KeyRead, rng: random.Random) -> object:
    """One value for `read` within what the loader allows: an end, the base value or inside."""
    kinds = list(EDGE_WEIGHTS)
    kind = rng.choices(kinds, weights=[EDGE_WEIGHTS[k] for k in kinds])[0]
    if kind == "base":
        return read.value
    drawer = _DRAWERS.get(read.kind)
    return read.value if drawer is None else drawer(read, kind, rng)


def _flag(_read: KeyRead, _kind: str, rng: random.Random) -> object:
    return rng.random() < 0.5


def _number(read: KeyRead, kind: str, rng: random.Random) -> object:
    assert isinstance(read.allowed, Interval)
    base = float(read.value)  # type: ignore[arg-type]
    if kind == "interior":
        return _interior(read.allowed, base, rng)
    return _number_edges(read.allowed, base)[kind]


def _integer(read: KeyRead, kind: str, rng: random.Random) -> object:
    assert isinstance(read.allowed, range)
    if kind == "interior":
        return rng.choice(read.allowed)
    return read.allowed.start if kind == "low" else read.allowed[-1]


def _shifted(read: KeyRead, kind: str, rng: random.Random) -> object:
    """A list of increasing integers (a switch's positions) moved as one: its first to the low
    end, its last to the high end, or anywhere between; its spacing kept."""
    assert isinstance(read.allowed, range)
    assert isinstance(read.value, tuple)
    values = [int(v) for v in read.value]
    lowest = read.allowed.start - values[0]
    highest = read.allowed[-1] - values[-1]
    shift = {"low": lowest, "high": highest}.get(kind)
    shift = rng.randint(lowest, highest) if shift is None else shift
    return [value + shift for value in values]


_DRAWERS: dict[str, Callable[[KeyRead, str, random.Random], object]] = {
    "flag": _flag,
    "number": _number,
    "integer": _integer,
    "integers": _shifted,
}


# --- a drawn file -------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Repair:
    """One drawn value moved toward the base file's until the loader took it (`kept`: the base
    value itself, or the nearest to the draw found by halving), and the refusal that moved it."""

    key: str
    # builtins.object: mypyc cannot load a field annotated `object` at import (issue 43)
    drawn: builtins.object
    kept: builtins.object
    base: builtins.object
    rule: str


@dataclass(slots=True)
class DrawnRobot:
    """One drawn robot file that loads: its text, its keys that differ from the base file
    (name: (base, drawn)), what was repaired on the way, and the rules that refused it on the
    way (each once)."""

    index: int
    text: str
    robot: RobotConfig
    changed: dict[str, tuple[object, object]]
    repairs: list[Repair] = field(default_factory=list)
    refusals: Counter[str] = field(default_factory=Counter)


def rule_of(message: str) -> str:
    """A refusal's rule: its deadline, or its key and reason with the values left out."""
    deadline = re.search(r"breaks the deadline '([^']+)'", message)
    if deadline:
        keys = message.split(": breaks the deadline", 1)[0]
        return f"{keys}: deadline '{deadline.group(1)}'"
    key, _, reason = message.partition(" = ")
    reason = reason.split(": ", 1)[1] if ": " in reason else reason
    return re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "#", f"{key}: {reason}".rstrip(": "))


def _set(data: dict[str, object], parts: tuple[str, ...], value: object) -> None:
    table = data
    for part in parts[:-1]:
        inner = table.get(part)
        if not isinstance(inner, dict):
            inner = {}
            table[part] = inner
        table = inner
    table[parts[-1]] = value


def _copy(data: Mapping[str, object]) -> dict[str, object]:
    return {k: _copy(v) if isinstance(v, Mapping) else v for k, v in data.items()}


def _problems(data: Mapping[str, object]) -> tuple[RobotConfig, list[tuple[str, str]]]:
    problems = Problems("<drawn robot file>")
    config = build_robot(data, problems)
    check_consistency(config, problems)
    return config, problems.entries


def draw_robot(schema: Schema, seed: int, index: int) -> DrawnRobot:
    """Robot file `index` of `seed`: every drawn key moved, then repaired until it loads."""
    rng = random.Random(f"bywire draw-robots {seed} {index}")
    drawn: dict[str, tuple[KeyRead, object]] = {}
    for read in schema.keys:
        value = draw_value(read, rng)
        if value != read.value and not (isinstance(value, list) and tuple(value) == read.value):
            drawn[dotted(read.parts)] = (read, value)
    first = {name: value for name, (_read, value) in drawn.items()}
    repairs: dict[str, Repair] = {}
    refusals: Counter[str] = Counter()
    halvings: Counter[str] = Counter()
    while True:
        data = _copy(schema.base)
        for read, value in drawn.values():
            _set(data, read.parts, value)
        config, entries = _problems(data)
        if not entries:
            break
        for key, message in entries:
            refusals[rule_of(message)] = 1  # a rule counts once a file
            name = _culprit(drawn, key, message, rng)
            if name is None:
                continue
            read, value = drawn.pop(name)
            halvings[name] += 1
            nearer = _toward(read, value) if halvings[name] <= MAX_HALVINGS else read.value
            if nearer != read.value:
                drawn[name] = (read, nearer)
            repairs[name] = Repair(name, first[name], nearer, read.value, rule_of(message))
        # every round moves a drawn key toward the base value, and after MAX_HALVINGS onto it:
        # this ends, at the base file at worst
    changed = {name: (read.value, value) for name, (read, value) in drawn.items()}
    return DrawnRobot(index, robot_text(data), config, changed, list(repairs.values()), refusals)


def _toward(read: KeyRead, value: object) -> object:
    """Half way from `value` back to the base value (a flag or a last step: the base value), so
    a refused edge is traded for the nearest value the other keys allow."""
    base = read.value
    if read.kind == "number" and isinstance(value, float | int) and isinstance(base, float | int):
        middle = round(base + (value - base) / 2, 9)
        return middle if middle != value else base
    if read.kind == "integer" and isinstance(value, int) and isinstance(base, int):
        return base + int((value - base) / 2)
    if read.kind == "integers" and isinstance(value, list) and isinstance(base, tuple):
        shift = int((value[0] - base[0]) / 2)
        return [item + shift for item in base] if shift else base
    return base


def _culprit(drawn: Mapping[str, object], key: str, message: str, rng: random.Random) -> str | None:
    """The one drawn key to put back for a refusal: the key it is reported under, else one it
    names, else one of its section; None when that refusal's keys are all back already."""
    if key in drawn:
        return key
    named = [name for name in drawn if _names(message, name)]
    section = key.split(".", maxsplit=1)[0]
    same = [name for name in drawn if name.split(".", maxsplit=1)[0] == section]
    named = named or same or list(drawn)
    return rng.choice(named) if named else None


def _names(message: str, name: str) -> bool:
    """Whether `message` names the key `name` (as a whole word)."""
    return re.search(rf"(?<![\w.]){re.escape(name)}(?![\w])", message) is not None


def draw_robots(schema: Schema, seed: int, count: int) -> Iterator[DrawnRobot]:
    """`count` drawn robot files of `seed`, each loadable, numbered from 1."""
    for index in range(1, count + 1):
        yield draw_robot(schema, seed, index)


# --- which drawn keys a failure needs ---------------------------------------------------------


def robot_with(schema: Schema, changed: Mapping[str, object]) -> tuple[str, RobotConfig] | None:
    """The base file with only `changed` (key: value) drawn, as text and robot; None if the
    loader refuses it."""
    reads = {dotted(read.parts): read for read in schema.keys}
    data = _copy(schema.base)
    for name, value in changed.items():
        _set(data, reads[name].parts, value)
    config, entries = _problems(data)
    return None if entries else (robot_text(data), config)


def keys_needed(
    schema: Schema,
    changed: Mapping[str, object],
    fails: Callable[[RobotConfig], bool],
) -> dict[str, object]:
    """The drawn keys (of `changed`, key: value) a failure needs: keys are put back to the base
    values in chunks (halves, quarters, … single ones, as the campaign shrinker drops steps),
    and a chunk stays back when the file still loads and `fails` still holds; single keys again
    until none goes. Every key left is one without which this failure goes (or the file no
    longer loads)."""
    needed = list(changed)

    def still_fails(keys: list[str]) -> bool:
        robot = robot_with(schema, {key: changed[key] for key in keys})
        return robot is not None and fails(robot[1])

    size = max(1, len(needed) // 2)
    while True:
        start, dropped = 0, False
        while start < len(needed):
            trial = needed[:start] + needed[start + size :]
            if still_fails(trial):
                needed, dropped = trial, True
            else:
                start += size
        if size == 1 and not dropped:
            return {key: changed[key] for key in needed}
        size = max(1, size // 2)


# --- the file as TOML ---------------------------------------------------------------------------


def robot_text(data: Mapping[str, object], header: str = "") -> str:
    """`data` as TOML text: plain keys first, then each table under its [header]."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    _emit(data, (), lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _emit(table: Mapping[str, object], path: tuple[str, ...], lines: list[str]) -> None:
    plain = {k: v for k, v in table.items() if not isinstance(v, Mapping)}
    tables = {k: v for k, v in table.items() if isinstance(v, Mapping)}
    if path and (plain or not tables):
        lines.append("")
        lines.append(f"[{dotted(path)}]")
    for key, value in plain.items():
        lines.append(f"{show_key(key)} = {toml_value(value)}")
    for key, inner in tables.items():
        assert isinstance(inner, Mapping)
        _emit(inner, (*path, key), lines)


def toml_value(value: object) -> str:
    """One value as TOML writes it (floats exactly, as Python's repr)."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    return show(value)
