"""The command table: a new CAN command the controller obeys is its DBC message, its row (a class
and a `CommandSpec`) and its rule, and everything else derives.

The horn is added in a child process (`tests/horn_row.py`), whose bywire loads its command table
and schedule table from source with the horn's class, row and task, and its CAN database with
the horn's message, before anything else imports them; nothing else is written for it. Judged on
the horn's line, the robot's mode and enable line, the frames on the bus, and the loader.
"""

from __future__ import annotations

import pytest

from bywire.command_table import COMMAND_TYPES, COMMANDS, MOVES_NOTHING, Use, command_row
from bywire.config import TimeoutsSection
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.hlc import SimHigherLevelComputer, mailboxes_needed
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlCommand, LightsCommand, MovementCommand
from bywire.protocol import dbc
from bywire.runtime.rx_checks import rx_checks
from tests.row_child import observed


@pytest.fixture(scope="module")
def horn() -> dict[str, object]:
    return observed("tests.horn_row")


def test_the_childs_row_is_new() -> None:
    """What the child adds is no row of the shipped table, nor a message of the shipped DBC."""
    assert "HornCommand" not in {kind.__name__ for kind in COMMAND_TYPES}
    assert "HornCommand" not in {message.name for message in dbc.database().messages}


def test_the_shipped_rows_say_what_the_controller_did_before_them() -> None:
    shipped = [command_row(kind) for kind in (ControlCommand, MovementCommand, LightsCommand)]
    assert COMMANDS[:3] == tuple(shipped)  # the simulated computer's order, kept
    assert [(spec.slot, spec.use, spec.moves_the_robot) for spec in shipped] == [
        ("control", Use.STOP_AND_RE_ENABLE, True),
        ("movement", Use.SET_POINTS, True),
        ("lights", Use.LIGHT_REQUESTS, False),
    ]
    assert LightsCommand in MOVES_NOTHING
    assert [check.kind for check in rx_checks(TimeoutsSection())] == list(COMMAND_TYPES)
    assert command_row(LightsCommand).timeout_key == "timeouts.can_message_timeout_s.LightsCommand"


def test_the_simulated_computer_sends_each_rows_neutral_frame_every_period() -> None:
    world = SimWorld.create(VirtualClock())
    world.start()
    world.clock.advance(0.999)
    sent = [frame for frame in world.bus.log if frame.sender == "hlc"]
    for spec in COMMANDS:
        frames = [frame for frame in sent if frame.arbitration_id == dbc.frame_id(spec.kind)]
        assert len(frames) == 50
        first = dbc.decode_intact(frames[0].arbitration_id, frames[0].data)
        assert first == spec.neutral  # counter 0 too: the first frame of its sequence
    assert world.hlc.refused == {}


def test_the_simulated_computers_mailboxes_are_sized_from_the_table() -> None:
    assert mailboxes_needed() == len(COMMANDS)
    assert mailboxes_needed(signing=True) == 2 * len(COMMANDS)
    assert isinstance(SimWorld.create(VirtualClock()).hlc, SimHigherLevelComputer)


def test_a_new_command_is_sent_by_the_simulated_computer_every_period(
    horn: dict[str, object],
) -> None:
    """One more command a period: it has its mailbox (three used to refuse a fourth)."""
    assert horn["row"] == ["HornCommand", "horn"]
    assert horn["hlc_mailboxes"] == len(COMMANDS) + 1
    assert horn["horn_frames_first_second"] == 50
    assert horn["hlc_refused"] == {}


def test_a_new_command_is_obeyed_and_times_out(horn: dict[str, object]) -> None:
    """Asked at 0.6 s, sounding at once; its frames lost from 1.0 s to 1.3 s (bad CRC): silent
    once its timeout has passed, and sounding again when they come back; the robot still in
    CAN mode all along: the horn's frames move nothing."""
    assert horn["sounding_at"] == {
        "0.55": False,
        "0.65": True,
        "0.90": True,
        "1.05": True,
        "1.30": False,
        "1.90": True,
    }
    assert horn["modes"] == {"0.9": "CAN", "1.3": "CAN", "2.3": "CAN"}


def test_a_new_command_is_refused_while_its_id_is_untrusted(horn: dict[str, object]) -> None:
    """A second sender on the horn's id asks for the horn the computer no longer asks for: the
    horn stays silent throughout (without the trust rule, the impostor's accepted frames sound
    it); the id's untrust is flagged, costs the horn alone, and passes when it leaves."""
    assert horn["sounding_while_untrusted"] == [False] * 45
    assert horn["untrusted"] == {"0.9": False, "1.3": False, "2.3": True}
    flags = horn["flags"]
    assert isinstance(flags, dict)
    assert "CAN_UNTRUSTED" in flags["2.3"]
    assert horn["causes"] == []
    assert horn["enabled_while_untrusted"] is True
    assert horn["sounding_after_untrusted"] is True


def test_a_new_command_is_the_can_modes_alone(horn: dict[str, object]) -> None:
    assert horn["sounding_in_rc_mode"] is False
    assert horn["sounding_at_end"] is False


def test_the_telemetry_state_has_a_new_commands_age(horn: dict[str, object]) -> None:
    """The state topic's inputs carry one age per command row (`can_<slot>_age_s`), and the
    schema with them: the horn's is fresh, its frames sent every period."""
    assert horn["telemetry_state_errors"] == []
    ages = horn["telemetry_horn_age_s"]
    assert isinstance(ages, dict)
    assert isinstance(ages["0.90"], float)
    assert 0.0 <= ages["0.90"] <= 0.04  # sent every 20 ms


def test_bywire_frame_prints_a_new_commands_frames(horn: dict[str, object]) -> None:
    """`bywire frame horn --sound`: a subcommand per row, its options from the message's fields;
    the frames decode (CRC and all) to what was asked, the counter going on from 15 to 0."""
    assert horn["frame_cli"] == {
        "status": 0,
        "frames": [["HornCommand", True, 15], ["HornCommand", True, 0]],
    }


def test_the_robot_file_names_a_new_commands_timeout(horn: dict[str, object]) -> None:
    assert horn["configured_timeout_s"] == 0.25
    assert horn["rx_check_timeout_s"] == [0.25]
    refusals = horn["refusals"]
    assert isinstance(refusals, dict)
    assert "timeouts.can_message_timeout_s.HornCommand = 0.03" in refusals["too_short"]
    assert "allowed >= 0.04 s" in refusals["too_short"]
