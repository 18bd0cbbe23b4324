"""Every tool that opens a bus takes python-can's and cantools' spelling of the bus options."""

from __future__ import annotations

import argparse

import can
import pytest

from bywire.cli.bus_options import add_bus_options, bus_from_args, bus_source
from bywire.cli.main import build_parser


def _parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_bus_options(parser)
    return parser.parse_args(argv)


@pytest.mark.parametrize("command", ["teleop", "monitor"])
def test_every_bus_tool_takes_the_same_options(command: str) -> None:
    args = build_parser(command).parse_args(
        [command, "-i", "virtual", "-c", "x", "--bus-kwargs", "receive_own_messages=true"]
    )
    assert (args.interface, args.channel) == ("virtual", "x")
    assert args.bus_kwargs == [("receive_own_messages", True)]


def test_bus_kwargs_are_read_as_python_cans_cli_reads_them() -> None:
    args = _parse("--bus-kwargs", "fd=true", "data_bitrate=2000000", "tq=12.5", "name=abc")
    assert dict(args.bus_kwargs) == {
        "fd": True,
        "data_bitrate": 2_000_000,
        "tq": 12.5,
        "name": "abc",
    }


def test_a_bus_kwarg_without_a_value_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        _parse("--bus-kwargs", "fd")
    assert "must be KEY=VALUE, got 'fd'" in capsys.readouterr().err


def test_the_bus_opens_with_the_extra_arguments() -> None:
    args = _parse("-i", "virtual", "-c", "bus-options", "--bus-kwargs", "receive_own_messages=true")
    bus = bus_from_args(args)
    try:
        bus.send(can.Message(arbitration_id=0x123, data=b"\x01", is_extended_id=False))
        echoed = bus.recv(1.0)  # receive_own_messages reached python-can
        assert echoed is not None
        assert echoed.arbitration_id == 0x123
    finally:
        bus.shutdown()
    assert bus_source(args) == "virtual bus-options"
    assert bus_source(_parse()) == "socketcand can0 @ 127.0.0.1:29536"
