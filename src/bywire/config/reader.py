"""Reading one TOML table: typed values with defaults, ranges checked, unknown keys refused.

A bad value is recorded in `Problems` and replaced by its default, so one pass over a file finds
every problem in it; `Problems.check` then raises them together as one ConfigError.
"""

from __future__ import annotations

import builtins
import difflib
import itertools
import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from bywire.errors import ConfigError

MISSING = object()
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
SHOWN_ITEMS = 3
_TOML_TYPES = (
    (bool, "a boolean"),
    (int, "an integer"),
    (float, "a float"),
    (str, "a string"),
    (list, "an array"),
    (Mapping, "a table"),
)


def show(value: object) -> str:
    """A value as TOML would write it, for messages: always one line."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, Mapping):
        items = [f"{show_key(str(key))} = {show(item)}" for key, item in value.items()]
        items[SHOWN_ITEMS:] = ["..."] if len(items) > SHOWN_ITEMS else []
        return "{ " + ", ".join(items) + " }" if items else "{}"
    return repr(value)


def show_key(name: str) -> str:
    """A key as TOML would write it: bare when it can be, else quoted (never a line break)."""
    return name if _BARE_KEY.fullmatch(name) else json.dumps(name)


def toml_type(value: object) -> str:
    """The TOML name of a value's type, with its article."""
    found = (name for kind, name in _TOML_TYPES if isinstance(value, kind))
    return next(found, "a date or time")


def finite(value: int | float) -> float | None:
    """The number as a float, or None when it is not finite (nan, inf) or too big for a float."""
    try:
        number = float(value)
    except OverflowError:  # an integer beyond 1.8e308
        return None
    return number if math.isfinite(number) else None


def number_text(value: float) -> str:
    """1000.0 as "1000", 0.0005 as "0.0005": short and exact."""
    if math.isfinite(value) and float(value).is_integer():
        return str(int(value))
    return repr(float(value))


@dataclass(frozen=True, slots=True)
class Interval:
    """Allowed numbers low…high, either end optionally open, with the unit for messages."""

    low: float
    high: float = math.inf
    unit: str = ""
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below  # NaN is never allowed

    def __str__(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        low, high = number_text(self.low), number_text(self.high)
        if self.low == self.high:
            return f"only {low}{unit}"
        if not (self.low_open or self.high_open or math.isinf(self.high)):
            return f"{low}..{high}{unit}"
        bounds = [f"{'>' if self.low_open else '>='} {low}"]
        if math.isfinite(self.high):
            bounds.append(f"{'<' if self.high_open else '<='} {high}")
        return " and ".join(bounds) + unit


class Problems:
    """Every problem found in one file, raised together as one ConfigError naming the file."""

    def __init__(self, origin: str) -> None:
        self.origin = origin
        self.entries: list[tuple[str, str]] = []

    def add(self, key: str, message: str) -> None:
        self.entries.append((key, message))

    def affects(self, *keys: str) -> bool:
        """True if any of `keys` (or anything below it) already has a problem."""
        return any(k == key or k.startswith(key + ".") for k, _ in self.entries for key in keys)

    def check(self) -> None:
        if len(self.entries) == 1:
            raise ConfigError(f"{self.origin}: {self.entries[0][1]}")
        if self.entries:
            lines = "".join(f"\n  {message}" for _, message in self.entries)
            raise ConfigError(f"{self.origin}: {len(self.entries)} problems:{lines}")


@dataclass(frozen=True, slots=True)
class KeyRead:
    """One key a reader asked for: where (the table names down from the root, then the key),
    what it may be (an Interval, a range, a choice of strings, or None: any string, a flag or a
    raw value the reader checks itself), the kind of reading, and the value it read (the
    default when the key is absent)."""

    parts: tuple[str, ...]
    kind: str  # "number", "integer", "integers" (count increasing), "numbers", "text", "flag"
    allowed: Interval | range | tuple[str, ...] | None
    value: builtins.object  # not `object`: mypyc cannot load that annotation (issue 43)
    count: int = 1


class Table:
    """One TOML table at a dotted path; every key read is remembered so the rest are unknown.
    With `schema` (a list shared down the tree), every typed reading is also recorded there as
    a KeyRead: the loader's own account of each key's allowed values (`bywire verify
    --draw-robots` draws from it)."""

    def __init__(
        self,
        data: Mapping[str, object],
        path: str,
        problems: Problems,
        schema: list[KeyRead] | None = None,
        parts: tuple[str, ...] = (),
    ) -> None:
        self.data, self.path, self.problems = data, path, problems
        self.schema, self.parts = schema, parts
        self._known: dict[str, None] = {}

    def _record(
        self,
        name: str,
        kind: str,
        allowed: Interval | range | tuple[str, ...] | None,
        value: object,
        count: int = 1,
    ) -> None:
        if self.schema is not None:
            self.schema.append(KeyRead((*self.parts, name), kind, allowed, value, count))

    def key(self, name: str) -> str:
        shown = show_key(name)
        return f"{self.path}.{shown}" if self.path else shown

    def get(self, name: str) -> object:
        """The raw value, or MISSING; marks `name` as a known key."""
        self._known[name] = None
        return self.data.get(name, MISSING)

    def refuse(self, name: str, value: object, reason: str) -> None:
        self.problems.add(self.key(name), f"{self.key(name)} = {show(value)}: {reason}")

    def number(self, name: str, default: float, allowed: Interval) -> float:
        number = self._number(name, default, allowed)
        self._record(name, "number", allowed, number)
        return number

    def _number(self, name: str, default: float, allowed: Interval) -> float:
        value = self.get(name)
        if value is MISSING:
            return default
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.refuse(name, value, f"expected a number in {allowed}, got {toml_type(value)}")
            return default
        number = finite(value)
        if number is None or number not in allowed:
            self.refuse(name, value, f"out of range; allowed {allowed}")
            return default
        return number

    def integer(
        self,
        name: str,
        default: int,
        allowed: range,
        show_int: Callable[[int], str] = str,
        why: str = "",
    ) -> int:
        """The integer at `name` (or `default`); out of `allowed`, a problem naming the range
        and, when given, `why` the range ends where it does."""
        integer = self._integer(name, default, allowed, show_int, why)
        self._record(name, "integer", allowed, integer)
        return integer

    def _integer(
        self, name: str, default: int, allowed: range, show_int: Callable[[int], str], why: str
    ) -> int:
        value = self.get(name)
        text = f"only {show_int(allowed.start)}" if len(allowed) == 1 else ""
        text = text or f"{show_int(allowed.start)}..{show_int(allowed[-1])}"
        if value is MISSING:
            return default
        if isinstance(value, bool) or not isinstance(value, int):
            self.refuse(name, value, f"expected an integer in {text}, got {toml_type(value)}")
            return default
        if value not in allowed:
            shown = f"{self.key(name)} = {show_int(value)}"
            reason = f" ({why})" if why else ""
            self.problems.add(self.key(name), f"{shown}: out of range; allowed {text}{reason}")
            return default
        return value

    def integer_list(
        self, name: str, default: tuple[int, ...], allowed: range, count: int
    ) -> tuple[int, ...]:
        """`count` strictly increasing integers in `allowed` at `name` (or `default`)."""
        integers = self._integer_list(name, default, allowed, count)
        self._record(name, "integers", allowed, integers, count)
        return integers

    def _integer_list(
        self, name: str, default: tuple[int, ...], allowed: range, count: int
    ) -> tuple[int, ...]:
        value = self.get(name)
        if value is MISSING:
            return default
        text = f"{count} increasing integers in {allowed.start}..{allowed[-1]}"
        if not isinstance(value, list) or len(value) != count:
            self.refuse(name, value, f"expected an array of {text}, got {toml_type(value)}")
            return default
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            self.refuse(name, value, f"expected {text}")
            return default
        if any(v not in allowed for v in value) or any(
            a >= b for a, b in itertools.pairwise(value)
        ):
            self.refuse(name, value, f"out of range or not increasing; allowed {text}")
            return default
        return tuple(value)

    def number_list(
        self, name: str, default: tuple[float, ...], allowed: Interval, counts: range, strict: bool
    ) -> tuple[float, ...]:
        """Numbers in `allowed` at `name` (or `default`), as many as `counts` allows, rising
        (strictly when `strict`): one axis of a calibration map."""
        numbers = self._number_list(name, default, allowed, counts, strict)
        self._record(name, "numbers", allowed, numbers, len(numbers))
        return numbers

    def _number_list(
        self, name: str, default: tuple[float, ...], allowed: Interval, counts: range, strict: bool
    ) -> tuple[float, ...]:
        value = self.get(name)
        if value is MISSING:
            return default
        order = "strictly rising" if strict else "rising"
        text = f"{counts.start}..{counts[-1]} {order} numbers, each {allowed}"
        if not isinstance(value, list) or len(value) not in counts:
            self.refuse(name, value, f"expected an array of {text}, got {toml_type(value)}")
            return default
        numbers = [
            None if isinstance(v, bool) or not isinstance(v, int | float) else finite(v)
            for v in value
        ]
        if any(n is None or n not in allowed for n in numbers):
            self.refuse(name, value, f"out of range; allowed {text}")
            return default
        checked = [float(n) for n in numbers if n is not None]
        if any(a >= b if strict else a > b for a, b in itertools.pairwise(checked)):
            self.refuse(name, value, f"not {order}; allowed {text}")
            return default
        return tuple(checked)

    def text(self, name: str, default: str, choices: Sequence[str] = ()) -> str:
        text = self._text(name, default, choices)
        self._record(name, "text", tuple(choices) or None, text)
        return text

    def _text(self, name: str, default: str, choices: Sequence[str]) -> str:
        value = self.get(name)
        allowed = "one of " + ", ".join(map(show, choices)) if choices else "a non-empty string"
        if value is MISSING:
            return default
        if not isinstance(value, str):
            self.refuse(name, value, f"expected {allowed}, got {toml_type(value)}")
        elif choices and value not in choices:
            guess = _guess(value, choices, show)
            self.refuse(name, value, f"not allowed; expected {allowed}{guess}")
        elif not value.strip():
            self.refuse(name, value, f"expected {allowed}")
        else:
            return value
        return default

    def flag(self, name: str, default: bool) -> bool:
        flag = self._flag(name, default)
        self._record(name, "flag", None, flag)
        return flag

    def _flag(self, name: str, default: bool) -> bool:
        value = self.get(name)
        if value is MISSING:
            return default
        if not isinstance(value, bool):
            self.refuse(name, value, f"expected true or false, got {toml_type(value)}")
            return default
        return value

    def table(self, name: str) -> Table:
        value = self.get(name)
        if value is not MISSING and not isinstance(value, Mapping):
            self.refuse(name, value, f"expected a table [{self.key(name)}], got {toml_type(value)}")
        data = value if isinstance(value, Mapping) else {}
        return Table(data, self.key(name), self.problems, self.schema, (*self.parts, name))

    def close(self) -> None:
        """Refuse every key that no reader asked for, suggesting the nearest known one."""
        known = list(self._known)
        for name, value in self.data.items():
            if name not in known:
                expected = ", ".join(known)
                guess = _guess(name, known, self.key)
                self.refuse(name, value, f"unknown key{guess}; known keys: {expected}")


def _guess(name: str, choices: Sequence[str], render: Callable[[str], str]) -> str:
    near = difflib.get_close_matches(name, choices, n=1, cutoff=0.6)
    return f" (did you mean {render(near[0])}?)" if near else ""
