"""ControlCommand edges between consecutive accepted frames."""

from __future__ import annotations

from bywire.control.command_edges import CommandEdges, command_edges
from bywire.model import ControlCommand

OFF = ControlCommand(remote_stop=False, re_enable=False, counter=0)
RE_ENABLE = ControlCommand(remote_stop=False, re_enable=True, counter=1)
STOP = ControlCommand(remote_stop=True, re_enable=False, counter=1)


def test_a_re_enable_edge_needs_a_previous_frame_without_it() -> None:
    assert command_edges(OFF, RE_ENABLE) == CommandEdges(re_enable=True)
    assert command_edges(RE_ENABLE, RE_ENABLE) == CommandEdges()
    assert command_edges(None, RE_ENABLE) == CommandEdges()


def test_a_remote_stop_arrives_with_the_first_frame_that_carries_it() -> None:
    assert command_edges(OFF, STOP) == CommandEdges(remote_stop=True)
    assert command_edges(None, STOP) == CommandEdges(remote_stop=True)
    assert command_edges(STOP, STOP) == CommandEdges()
