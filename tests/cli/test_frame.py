"""`bywire frame`: frames for cansend that pass the controller's own checks (counter, CRC, MAC)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.model import ControlCommand, Gear, LightsCommand, MovementCommand
from bywire.protocol import dbc
from bywire.security.keys import new_key_file
from bywire.security.session import SecocReceiver


def _bywire(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


def _parsed(line: str) -> tuple[int, bytes]:
    """A cansend argument back to (id, data), as can-utils parses `ID#HEX`."""
    frame_id, _, data = line.partition("#")
    return int(frame_id, 16), bytes.fromhex(data)


def test_a_run_of_movement_frames_passes_the_controllers_counter_and_crc_checks() -> None:
    status, out, err = _bywire(
        "frame", "movement", "--steering", "-0.25", "--throttle", "0.2", "--gear", "forward",
        "--counter", "14", "--count", "4",
    )  # fmt: skip
    assert (status, err) == (0, "")
    previous = None
    counters = []
    for line in out.splitlines():
        frame_id, data = _parsed(line)
        command = dbc.decode_command(frame_id, data, previous)  # raises on a bad CRC or counter
        assert isinstance(command, MovementCommand)
        assert command.gear is Gear.FORWARD
        assert command.steering_norm == pytest.approx(-0.25)
        assert command.throttle_norm == pytest.approx(0.2, abs=0.01)
        previous = command.counter
        counters.append(command.counter)
    assert counters == [14, 15, 0, 1]


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["control", "--re-enable"], ControlCommand(False, True, 0)),
        (["control", "--remote-stop", "--counter", "3"], ControlCommand(True, False, 3)),
        (["lights", "--low-beam", "--hazard"], LightsCommand(False, False, True, True, 0)),
    ],
)
def test_control_and_lights_frames_decode_to_what_was_asked(
    argv: list[str], expected: ControlCommand | LightsCommand
) -> None:
    status, out, _ = _bywire("frame", *argv)
    assert status == 0
    assert dbc.decode_command(*_parsed(out.strip()), None) == expected


def test_with_a_key_each_frame_is_followed_by_a_pdu_the_controller_verifies(
    tmp_path: Path,
) -> None:
    key = new_key_file(tmp_path / "robot.key")
    freshness = tmp_path / "sender.json"
    argv = ["frame", "control", "--re-enable", "--key", str(tmp_path / "robot.key")]
    argv += ["--trip", "7"]  # the trip counter the robot announces
    status, out, _ = _bywire(*argv, "--count", "2", "--freshness", str(freshness))
    assert status == 0
    receiver = SecocReceiver(key, 7, dbc.command_ids())
    lines = out.splitlines()
    assert [line[:4] for line in lines] == ["100#", "110#", "100#", "110#"]
    verified = [receiver.offer(*_parsed(line), 0.0).verified for line in lines]
    assert [v for v in verified if v is not None] == [_parsed(lines[0]), _parsed(lines[2])]
    # a second run goes on from the persisted freshness: its frames are not replays
    _, again, _ = _bywire(*argv, "--freshness", str(freshness))
    assert [receiver.offer(*_parsed(line), 0.0).verified for line in again.splitlines()][1]


@pytest.mark.parametrize(
    "argv",
    [
        ["movement", "--throttle", "1.5"],
        ["movement", "--steering", "nan"],
        ["control", "--counter", "16"],
        ["lights", "--count", "0"],
    ],
)
def test_a_value_outside_its_range_is_one_line_and_exit_2(argv: list[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        _bywire("frame", *argv)
    assert exited.value.code == 2


def test_a_key_without_the_robots_trip_or_a_trip_below_this_senders_is_one_line_and_exit_2(
    tmp_path: Path,
) -> None:
    new_key_file(tmp_path / "robot.key")
    signed = ["frame", "control", "--key", str(tmp_path / "robot.key")]
    signed += ["--freshness", str(tmp_path / "sender.json")]
    assert _bywire(*signed, "--trip", "9")[0] == 0  # this sender signs in trip 9 from now on
    for argv in (signed, [*signed, "--trip", "8"]):
        status, out, err = _bywire(*argv)
        assert status == 2
        assert out == ""  # nothing that cannot verify is printed
        assert len(err.strip().splitlines()) == 1
        assert "trip" in err
