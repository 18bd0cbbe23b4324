"""`@value`: immutable value types built in half the time a frozen dataclass takes.

`@value` is `@dataclass(frozen=True, slots=True)` and nothing else changes (fields, defaults,
`field(default_factory=...)`, `__post_init__`, equality, hashing, repr, `dataclasses.replace`,
and assignment to a field raising FrozenInstanceError), except how `__init__` stores the fields.
A frozen dataclass's `__init__` stores each one with `object.__setattr__(self, "name", value)`,
a generic attribute lookup by name per field; ours calls each field's slot descriptor directly.
The decision builds a dozen such values on every pass of the loop (about 100 fields), which made
this a sixth of its time (bench/RESULTS.md, run K); the sensor readings, the simulated vehicle's
state and the simulator's observations are built as often and use it too. Values built once (the
configuration) keep the plain decorator.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable
from typing import Any, TypeVar, dataclass_transform

T = TypeVar("T")


@dataclass_transform(frozen_default=True, field_specifiers=(dataclasses.field,))
def value(cls: type[T]) -> type[T]:
    """A frozen, slotted dataclass whose `__init__` stores fields through their slots."""
    built = dataclasses.dataclass(frozen=True, slots=True)(cls)
    _check_plain_fields(built)
    built.__init__ = _slot_init(built)  # type: ignore[method-assign]
    return built


def _check_plain_fields(cls: type[Any]) -> None:
    """TypeError unless the dataclass' own `__init__` takes exactly its fields, in order, each by
    position or keyword: `_slot_init` knows no `init=False`, `kw_only` or `InitVar`, and must not
    make an `__init__` that differs from the one it replaces."""
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]
    names = [parameter.name for parameter in parameters]
    plain = all(parameter.kind is parameter.POSITIONAL_OR_KEYWORD for parameter in parameters)
    if not plain or names != [field.name for field in dataclasses.fields(cls)]:
        raise TypeError(
            f"@value {cls.__qualname__}: every field must be an ordinary init field"
            " (no init=False, kw_only or InitVar); use @dataclass(frozen=True, slots=True)"
        )


_FACTORY = object()  # the default of a field that has a default_factory: call it


def _slot_init(cls: type[Any]) -> Callable[..., None]:
    """The same signature as the dataclass' own `__init__`, storing through the slots.

    Generated from source, as `dataclasses` generates its own: one line per field,
    `_set_name(self, name)`, where `_set_name` is the slot descriptor's `__set__`.
    """
    namespace: dict[str, Any] = {"_FACTORY": _FACTORY}
    parameters: list[str] = []
    lines: list[str] = []
    for field in dataclasses.fields(cls):
        name = field.name
        namespace[f"_set_{name}"] = cls.__dict__[name].__set__
        if field.default is not dataclasses.MISSING:
            namespace[f"_default_{name}"] = field.default
            parameters.append(f"{name}=_default_{name}")
        elif field.default_factory is not dataclasses.MISSING:
            namespace[f"_factory_{name}"] = field.default_factory
            parameters.append(f"{name}=_FACTORY")
            lines.append(f"if {name} is _FACTORY: {name} = _factory_{name}()")
        else:
            parameters.append(name)
        lines.append(f"_set_{name}(self, {name})")
    if hasattr(cls, "__post_init__"):
        lines.append("self.__post_init__()")
    body = "\n    ".join(lines or ["pass"])
    source = f"def __init__(self, {', '.join(parameters)}) -> None:\n    {body}\n"
    exec(source, namespace)
    init: Callable[..., None] = namespace["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    return init
