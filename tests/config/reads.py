"""Which configuration values the running code reads: a recorder on the config's own instances.

A key that loads and validates but that nothing reads is a number the user changes to no effect:
the robot, the simulator and `bywire verify` go on with the default. `install(config)` replaces
each field of every config dataclass class with a descriptor that records `path.field` (such as
`timeouts.watchdog_s`) whenever bywire's code outside the loader reads it from one of `config`'s
instances. Reads by the loader, the validators and the renderer (`CHECKING`), by the dataclass'
own methods (`__eq__`, `__hash__`, `__repr__`) and by tests do not count: they are not a use.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Iterator
from typing import Any

CHECKING = tuple(
    f"bywire.config.{name}"
    for name in (
        "loader",
        "reader",
        "sections",
        "actuators",
        "security",
        "consistency",
        "hazards",
        "limits",
        "render",
    )
)
"""Modules that read every value to parse, check or print it."""


def _dataclass_values(value: Any) -> Iterator[tuple[str, Any]]:
    """(suffix, item) for a dataclass' fields, a sequence's items or a mapping's values."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        for field in dataclasses.fields(value):
            yield f".{field.name}", getattr(value, field.name)
    elif isinstance(value, tuple | list):
        for index, item in enumerate(value):
            yield f"[{index}]", item
    elif isinstance(value, dict):
        for key, item in value.items():
            yield f"[{key}]", item


def leaves(config: Any, path: str = "") -> set[str]:
    """Every path of a value that is not itself a dataclass (mappings and tuples are values)."""
    found: set[str] = set()
    for suffix, item in _dataclass_values(config) if dataclasses.is_dataclass(config) else ():
        where = f"{path}{suffix}".lstrip(".")
        if dataclasses.is_dataclass(item):
            found |= leaves(item, where)
        else:
            found.add(where)
    return found


class Recorder:
    """Records reads of `config`'s fields by path; `uninstall` puts the classes back."""

    def __init__(self) -> None:
        self.reads: set[str] = set()
        self._paths: dict[int, list[str]] = {}
        self._keep: list[Any] = []  # the walked instances stay alive, so their ids stay theirs
        self._installed: list[tuple[type, str, Any]] = []

    def install(self, config: Any) -> None:
        self._walk(config, "")

    def _walk(self, value: Any, path: str) -> None:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            self._paths.setdefault(id(value), []).append(path)
            self._keep.append(value)
            self._record_class(type(value))
        for suffix, item in _dataclass_values(value):
            self._walk(item, f"{path}{suffix}".lstrip("."))

    def _record_class(self, cls: type) -> None:
        if any(installed is cls for installed, _, _ in self._installed):
            return
        for field in dataclasses.fields(cls):
            slot = cls.__dict__[field.name]
            self._installed.append((cls, field.name, slot))
            setattr(cls, field.name, _Recording(self, field.name, slot))

    def note(self, instance: object, name: str) -> None:
        caller = sys._getframe(2)
        module = caller.f_globals.get("__name__", "")
        method = caller.f_code.co_name
        if not module.startswith("bywire.") or module in CHECKING:
            return
        if method.startswith("__") and method.endswith("__"):
            return
        for path in self._paths.get(id(instance), ()):
            self.reads.add(f"{path}.{name}".lstrip("."))

    def uninstall(self) -> None:
        for cls, name, slot in reversed(self._installed):
            setattr(cls, name, slot)
        self._installed.clear()

    def unread(self, config: Any) -> set[str]:
        """The leaves of `config` that nothing read (a mapping counts if any entry was read)."""
        return {
            path
            for path in leaves(config)
            if path not in self.reads
            and not any(read.startswith(f"{path}[") for read in self.reads)
        }


class _Recording:
    """A field's slot descriptor that tells the recorder first."""

    def __init__(self, recorder: Recorder, name: str, slot: Any) -> None:
        self.recorder, self.name, self.slot = recorder, name, slot

    def __get__(self, instance: object, owner: type | None = None) -> Any:
        if instance is None:
            return self.slot.__get__(instance, owner)
        self.recorder.note(instance, self.name)
        return self.slot.__get__(instance, owner)

    def __set__(self, instance: object, value: Any) -> None:
        self.slot.__set__(instance, value)
