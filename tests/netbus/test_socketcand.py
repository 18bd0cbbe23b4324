"""The socketcand text codec against python-can's own client-side conversions."""

from __future__ import annotations

import can
import pytest
from can.interfaces.socketcand import socketcand as client

from bywire.errors import FrameError
from bywire.netbus import socketcand


@pytest.mark.parametrize(
    ("frame_id", "data", "extended"),
    [(0x201, bytes(range(8)), False), (0x7FF, b"", False), (0x1ABCDE0, b"\xff", True)],
)
def test_python_can_reads_our_frame_lines(frame_id: int, data: bytes, extended: bool) -> None:
    line = socketcand.frame_line(frame_id, 1712.0005, data, extended)
    message = client.convert_ascii_message_to_can_message(line)
    assert (message.arbitration_id, bytes(message.data)) == (frame_id, data)
    assert message.is_extended_id == extended
    assert message.timestamp == pytest.approx(1712.0005)


def test_a_frame_line_is_formatted_as_socketcand_does() -> None:
    assert socketcand.frame_line(0x201, 23.424242, b"\x11\x22", False) == (
        "< frame 201 23.424242 1122 >"
    )


@pytest.mark.parametrize(
    ("frame_id", "data", "extended"), [(0x101, bytes([0, 0x10, 0xAB]), False), (0x123, b"", False)]
)
def test_we_read_python_cans_send_commands(frame_id: int, data: bytes, extended: bool) -> None:
    message = can.Message(arbitration_id=frame_id, data=data, is_extended_id=extended)
    commands, rest = socketcand.split_commands(client.convert_can_message_to_ascii_message(message))
    assert rest == ""
    assert socketcand.parse_send(commands[0]) == socketcand.SendRequest(frame_id, data, extended)


def test_commands_are_split_across_reads() -> None:
    commands, rest = socketcand.split_commands("< open can0 >\r\n<rawmode> < send 1")
    assert commands == ["open can0", "rawmode"]
    assert rest == "< send 1"
    assert socketcand.split_commands(rest + "23 1 ff >")[0] == ["send 123 1 ff"]


@pytest.mark.parametrize(
    "text",
    ["junk< open can0 >", "POST / HTTP/1.1\r\n", "< open <can0 >", "<" + "x" * 1000],
    ids=["outside", "http", "nested", "endless"],
)
def test_what_is_not_the_protocol_is_refused(text: str) -> None:
    with pytest.raises(socketcand.ProtocolError):
        socketcand.split_commands(text)


@pytest.mark.parametrize("data", [b"\xff", b"\x00", "é".encode(), b"\x1b[2J"])
def test_only_printable_ascii_is_text(data: bytes) -> None:
    with pytest.raises(socketcand.ProtocolError, match="is not ASCII text"):
        socketcand.ascii_text(b"< open " + data)
    assert socketcand.ascii_text(b"< open can0 >\t\r\n") == "< open can0 >\t\r\n"


@pytest.mark.parametrize(
    "command",
    ["send", "send 800 0", "send 101 2 1", "send 101 1 zz", "send 101 9 1 2 3 4 5 6 7 8 9", "open"],
)
def test_a_malformed_send_is_refused(command: str) -> None:
    with pytest.raises(FrameError):
        socketcand.parse_send(command)
