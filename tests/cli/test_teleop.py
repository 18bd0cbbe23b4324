"""`bywire teleop` from the command line: help with the keys, bus errors as one line, exit 2."""

from __future__ import annotations

import socket
from pathlib import Path

import can
import pytest

from bywire.cli import teleop
from bywire.cli.main import main
from bywire.security.session import SecocSigner
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
    monkeypatch.setattr(teleop, "run_app", lambda bus, _signer=None: seen.append(bus))
    assert main(["teleop", "-i", "virtual", "-c", "teleop-cli-test"]) == 0
    [bus] = seen
    assert bus.channel_info.startswith("Virtual bus")
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False))


def test_with_a_key_every_command_is_signed_and_freshness_kept(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    signers: list[SecocSigner | None] = []
    monkeypatch.setattr(teleop, "run_app", lambda _bus, signer=None: signers.append(signer))
    key = tmp_path / "k.key"
    assert main(["keys", "new", str(key)]) == 0
    freshness = tmp_path / "state" / "teleop.json"
    argv = ["teleop", "-i", "virtual", "-c", "teleop-key-test", "--key", str(key)]
    assert main([*argv, "--freshness", str(freshness)]) == 0
    [signer] = signers
    assert signer is not None
    assert signer.authenticator(0x101, bytes(8)).arbitration_id == 0x111
    signer.close()
    assert freshness.exists()


def test_a_key_others_can_read_is_refused_before_the_bus_opens(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    key = tmp_path / "k.key"
    assert main(["keys", "new", str(key)]) == 0
    key.chmod(0o644)
    assert main(["teleop", "-i", "virtual", "-c", "x", "--key", str(key)]) == 2
    assert "key file has mode 0644" in capsys.readouterr().err
