"""The newest stamped frame of each CAN command message, keyed by its type: one slot per row.

The shell's slots between decisions, the inputs a decision was taken on and the arrivals that may
change it are all this one mapping, so a new row of `bywire.command_table` has its slot
everywhere at once. It is immutable: the shell replaces it as frames arrive
(`with_frames`), so a decision keeps what it saw, and "nothing new" is the same object.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar

from bywire.control.validity import Stamped
from bywire.model import Command

C = TypeVar("C", bound=Command)


class CommandSlots:
    """Each command message's newest stamped frame, None until first seen."""

    __slots__ = ("_frames",)

    def __init__(self, frames: Mapping[type[Command], Stamped[Any]] | None = None) -> None:
        self._frames: dict[type[Command], Stamped[Any]] = {} if frames is None else dict(frames)

    def get(self, kind: type[C]) -> Stamped[C] | None:
        """The newest frame of `kind`, stamped with its arrival; None until first seen."""
        return self._frames.get(kind)  # Stamped[Any]: no cast, a call on every pass

    def with_frames(self, *frames: Stamped[Any] | None) -> CommandSlots:
        """These slots with each frame the newest of its message (None: nothing new)."""
        newest = dict(self._frames)
        for frame in frames:
            if frame is not None:
                newest[type(frame.value)] = frame
        return CommandSlots(newest)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, CommandSlots) and other._frames == self._frames

    def __hash__(self) -> int:
        return hash(frozenset(self._frames.items()))

    def __repr__(self) -> str:
        frames = ", ".join(f"{kind.__name__}: {frame}" for kind, frame in self._frames.items())
        return f"CommandSlots({{{frames}}})"


NO_COMMANDS = CommandSlots()
"""Nothing seen yet: every slot empty."""


def received(*frames: Stamped[Any] | None) -> CommandSlots:
    """The slots holding these frames (None: a slot left empty), each the newest of its message."""
    return NO_COMMANDS.with_frames(*frames)
