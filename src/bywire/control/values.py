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
import types
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


SOURCE_INITS: dict[type[Any], Callable[..., None]] = {}
"""Each class `slot_init` gave a faster `__init__` in the pure build: the `__init__` its source
wrote (tests/control/test_values.py checks that the two store the same)."""


def slot_init(cls: type[Any]) -> None:
    """The pure build's `__init__` of a value the compiled build makes native (issue 43).

    mypyc compiles a class decorated by `@value` (a function it does not know) as an ordinary
    Python class: every field read through a generic attribute lookup, every value built by the
    exec'd `__init__`. A `@dataclass(frozen=True, slots=True)` is a native class, and an
    `__init__` written in its body that stores each field, in order, with
    `object.__setattr__(self, "name", name)` compiles to a store into the struct. Interpreted,
    that `__init__` is slower than `@value`'s, so in the pure build this replaces it with
    `@value`'s (after checking that it takes the same parameters, with equal defaults, as the
    fields); in the compiled build the class's `__init__` is no Python function and is kept.
    Call it after the class (a decorator would make the class non-native again).
    """
    written = cls.__dict__.get("__init__")
    if not isinstance(written, types.FunctionType):
        return  # compiled
    _check_plain_fields(cls)
    fields = dataclasses.fields(cls)
    defaults = [parameter.default for parameter in inspect.signature(written).parameters.values()]
    wanted = [field.default for field in fields]
    if len(defaults) != len(fields) + 1 or any(
        (a is inspect.Parameter.empty) != (b is dataclasses.MISSING)
        or (b is not dataclasses.MISSING and a != b)
        for a, b in zip(defaults[1:], wanted, strict=True)
    ):
        raise TypeError(f"slot_init {cls.__qualname__}: __init__'s defaults are not its fields'")
    if any(field.default_factory is not dataclasses.MISSING for field in fields):
        raise TypeError(f"slot_init {cls.__qualname__}: no default_factory (give a default value)")
    SOURCE_INITS[cls] = written
    cls.__init__ = _slot_init(cls)
