"""Edges of the ControlCommand's two requests, taken between consecutive accepted frames.

A re-enable acts on its rising edge only, and an edge is a 0→1 change between two *consecutive
accepted* frames of the message: the reader forgets the previous frame after a gap longer than
the command timeout or after a rejected frame, so a request held across a gap, or across a frame
the codec refused, never becomes an edge (a deliberate act needs a 0 the controller has seen).
A remote stop, in the safe direction, counts as arriving on the first frame that carries it when
there is no previous frame to compare with.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.values import slot_init
from bywire.model import ControlCommand


@dataclass(frozen=True, slots=True)
class CommandEdges:
    """What a ControlCommand frame changed against the frame before it."""

    re_enable: bool = False
    remote_stop: bool = False

    def __init__(self, re_enable: bool = False, remote_stop: bool = False) -> None:
        object.__setattr__(self, "re_enable", re_enable)
        object.__setattr__(self, "remote_stop", remote_stop)


slot_init(CommandEdges)


NO_EDGES = CommandEdges()


def command_edges(previous: ControlCommand | None, current: ControlCommand) -> CommandEdges:
    """The edges `current` makes; `previous` is None when there is no frame to compare with."""
    return CommandEdges(
        re_enable=current.re_enable and previous is not None and not previous.re_enable,
        remote_stop=current.remote_stop and (previous is None or not previous.remote_stop),
    )
