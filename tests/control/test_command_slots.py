"""The command slots: one per command row, keyed by type, immutable, each the newest frame."""

from __future__ import annotations

from dataclasses import replace

from bywire.control.command_slots import NO_COMMANDS, CommandSlots, received
from bywire.control.validity import Stamped
from bywire.model import LIGHTS_OFF, ControlCommand, Gear, LightsCommand, MovementCommand

MOVING = Stamped(MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, 3), 0.5)
LAMPS = Stamped(replace(LIGHTS_OFF, hazard=True), 0.4)


def test_a_slot_is_empty_until_its_first_frame() -> None:
    assert NO_COMMANDS.get(MovementCommand) is None
    slots = received(MOVING)
    assert slots.get(MovementCommand) is MOVING
    assert slots.get(LightsCommand) is None
    assert slots.get(ControlCommand) is None


def test_a_new_frame_replaces_its_own_slot_alone_and_leaves_the_old_slots_as_they_were() -> None:
    before = received(MOVING, LAMPS)
    newer = Stamped(replace(MOVING.value, counter=4), 0.52)
    after = before.with_frames(newer, None)
    assert after.get(MovementCommand) is newer
    assert after.get(LightsCommand) is LAMPS
    assert before.get(MovementCommand) is MOVING  # what a decision saw stays as it saw it
    assert after != before


def test_slots_compare_by_their_frames() -> None:
    assert received(MOVING, LAMPS) == received(LAMPS, MOVING)
    assert hash(received(MOVING, LAMPS)) == hash(received(LAMPS, MOVING))
    assert received(MOVING) != received(LAMPS)
    assert CommandSlots() == NO_COMMANDS
    assert "MovementCommand" in repr(received(MOVING))
