"""`bywire teleop` from the command line: help with the keys, bus errors as one line, exit 2."""

from __future__ import annotations

import socket

import can
import pytest

from bywire.cli import teleop
from bywire.cli.main import main
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
    monkeypatch.setattr(teleop, "run_app", seen.append)
    assert main(["teleop", "-i", "virtual", "-c", "teleop-cli-test"]) == 0
    [bus] = seen
    assert bus.channel_info.startswith("Virtual bus")
    with pytest.raises(can.CanOperationError):
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False))
