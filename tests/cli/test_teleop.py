"""`bywire teleop` from the command line: help with the keys, bus errors as one line, exit 2."""

from __future__ import annotations

import json
import os
import shutil
import socket
import sys
import tempfile
import traceback
from pathlib import Path

import can
import pytest

from bywire.cli import teleop
from bywire.cli.main import main
from bywire.protocol import dbc
from bywire.security.keys import read_key_file
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.teleop.state import KEYS


def test_help_explains_every_key(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["teleop", "--help"])
    assert exited.value.code == 0
    out = capsys.readouterr().out
    for binding in KEYS:
        assert f"  {binding.key:<7} {binding.label}" in out
    assert "bywire sim --realtime --serve 29536" in out
    assert "bywire teleop -i socketcan -c can0" in out


def test_an_unknown_interface_is_refused_naming_the_known_ones(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["teleop", "-i", "nosuchbus"])
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert "argument -i/--interface: invalid choice: 'nosuchbus'" in err
    assert "socketcand" in err


def _closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def test_no_simulator_listening_says_how_to_start_one(capsys: pytest.CaptureFixture[str]) -> None:
    port = _closed_port()
    assert main(["teleop", "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert f"nothing answers on 127.0.0.1 port {port}" in err
    assert f"bywire sim --realtime --serve {port}" in err
    assert err.count("\n") == 1


def test_the_app_runs_on_the_opened_bus_which_is_closed_after(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: list[can.BusABC] = []
    monkeypatch.setattr(
        teleop, "run_app", lambda bus, _gamepad=None, _signer=None: seen.append(bus)
    )
    assert main(["teleop", "-i", "virtual", "-c", "teleop-cli-test"]) == 0
    [bus] = seen
    assert bus.channel_info.startswith("Virtual bus")
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False))


# --- --gamepad: every failure to open is one line naming the fix, exit 2 ------------------------


def test_help_shows_the_gamepad_mapping(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["teleop", "--help"])
    out = capsys.readouterr().out
    assert "--gamepad [DEVICE]" in out
    assert teleop.GAMEPAD_HELP in out
    assert "group 'input'" in out


def _refusal(capsys: pytest.CaptureFixture[str], *arguments: str) -> str:
    assert main(["teleop", *arguments, "-i", "virtual", "-c", "gamepad-cli-test"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def test_a_missing_gamepad_device_is_named(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("evdev")
    err = _refusal(capsys, "--gamepad", "/dev/input/event99-none")
    assert "no gamepad at /dev/input/event99-none: the file does not exist" in err


def test_a_file_that_is_no_input_device_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("evdev")
    fake = tmp_path / "event0"
    fake.write_bytes(b"")
    err = _refusal(capsys, "--gamepad", str(fake))
    assert f"cannot open the gamepad {fake}" in err
    assert "event device" in err


def test_no_gamepad_in_the_input_folder_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("evdev")
    from bywire.teleop import gamepad_device  # noqa: PLC0415

    monkeypatch.setattr(gamepad_device, "INPUT_DIR", tmp_path)
    (tmp_path / "event0").write_bytes(b"")  # not an input device: passed over
    err = _refusal(capsys, "--gamepad")
    assert f"no gamepad found in {tmp_path}" in err


def test_without_evdev_the_fix_is_named(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "evdev", None)  # as where it is not installed
    for module in ("bywire.teleop.gamepad", "bywire.teleop.gamepad_device"):
        monkeypatch.delitem(
            sys.modules, module, raising=False
        )  # imported afresh, as in a new process
    err = _refusal(capsys, "--gamepad")
    assert "--gamepad needs the evdev package (Linux only)" in err
    assert "pip install 'bywire[gamepad]'" in err


NOBODY = 65534


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to become another user in a child")
def test_an_unreadable_gamepad_names_the_input_group() -> None:
    """A root-only file read by user nobody: the permission error a user outside `input` gets.

    A forked child drops to nobody after the modules are imported (the venv may be root's) and
    runs the command; its exit status and stderr come back through the parent.
    """
    pytest.importorskip("evdev")
    import bywire.teleop.gamepad_device  # noqa: F401, PLC0415 -- imported before dropping root

    folder = Path(tempfile.mkdtemp(prefix="bywire-input-", dir="/tmp"))  # nobody may enter it
    folder.chmod(0o755)
    device = folder / "event7"
    device.write_bytes(b"")
    device.chmod(0o600)
    read_end, write_end = os.pipe()
    child = os.fork()
    if child == 0:  # pragma: no cover -- the child reports through its exit status and pipe
        code = 3
        try:
            os.dup2(write_end, 2)
            sys.stderr = os.fdopen(2, "w", buffering=1)
            os.setegid(NOBODY)
            os.seteuid(NOBODY)
            code = main(["teleop", "--gamepad", str(device), "-i", "virtual", "-c", "x"])
        except BaseException:
            traceback.print_exc()
        finally:
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end) as pipe:
        err = pipe.read()
    _, status = os.waitpid(child, 0)
    shutil.rmtree(folder)
    assert os.waitstatus_to_exitcode(status) == 2, err
    assert err.count("\n") == 1, err
    assert f"cannot read the gamepad {device}: permission denied" in err
    assert "add yourself to the group 'input'" in err


def test_with_a_key_every_command_is_signed_and_freshness_kept(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    signers: list[SecocSigner | None] = []

    def run_app(
        _bus: can.BusABC, _gamepad: object = None, signer: SecocSigner | None = None
    ) -> None:
        signers.append(signer)

    monkeypatch.setattr(teleop, "run_app", run_app)
    key = tmp_path / "k.key"
    assert main(["keys", "new", str(key)]) == 0
    freshness = tmp_path / "state" / "teleop.json"
    argv = ["teleop", "-i", "virtual", "-c", "teleop-key-test", "--key", str(key)]
    assert main([*argv, "--freshness", str(freshness)]) == 0
    [signer] = signers
    assert signer is not None
    assert signer.authenticator(0x101, bytes(8)) is None  # not before the robot's trip counter
    receiver = SecocReceiver(read_key_file(key), 5, dbc.command_ids())
    for frame_id, data in receiver.announcement:
        signer.hear(frame_id, data)
    authenticator = signer.authenticator(0x101, bytes(8))
    assert authenticator is not None
    assert authenticator.arbitration_id == 0x111
    signer.close()
    assert json.loads(freshness.read_text())["trip"] == 5


def test_a_key_others_can_read_is_refused_before_the_bus_opens(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    key = tmp_path / "k.key"
    assert main(["keys", "new", str(key)]) == 0
    key.chmod(0o644)
    assert main(["teleop", "-i", "virtual", "-c", "x", "--key", str(key)]) == 2
    assert "key file has mode 0644" in capsys.readouterr().err
