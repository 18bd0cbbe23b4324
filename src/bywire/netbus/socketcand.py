"""The socketcand text protocol (raw mode), server side: pure formatting and parsing, no I/O.

A session, as python-can's ``socketcand`` interface and cantools speak it::

    server                         client
    < hi >                   -->
                             <--   < open can0 >
    < ok >                   -->
                             <--   < rawmode >
    < ok >                   -->
    < frame 201 1712.000500 0011223344556677 >      every frame on the bus (id hex, time s.us)
                             <--   < send 101 8 1 2 3 4 5 6 7 8 >   a frame for the bus (hex)

Ids of three hex digits are standard (11-bit), eight digits extended. A command the session
cannot take gets ``< error … >``; bytes that are not the protocol at all (not ASCII, text outside
the brackets, an endless command) are a `ProtocolError`, and the server closes the connection.
Reference: github.com/linux-can/socketcand, doc/protocol.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.errors import FrameError

HELLO = "< hi >"
OK = "< ok >"
MAX_COMMAND_CHARS = 256  # a send command with 8 bytes is < 50: anything longer is garbage


@dataclass(frozen=True, slots=True)
class SendRequest:
    """A client's ``< send … >``: one frame for the bus."""

    arbitration_id: int
    data: bytes
    is_extended_id: bool


def error(text: str) -> str:
    """An error reply."""
    return f"< error {text} >"


def frame_line(arbitration_id: int, timestamp_s: float, data: bytes, extended: bool) -> str:
    """The ``< frame … >`` line for one frame, formatted as socketcand itself does."""
    frame_id = f"{arbitration_id:08X}" if extended else f"{arbitration_id:03X}"
    seconds, micros = divmod(round(timestamp_s * 1e6), 1_000_000)
    return f"< frame {frame_id} {seconds}.{micros:06d} {data.hex().upper()} >"


class ProtocolError(FrameError):
    """What a client sent is not the socketcand protocol: the connection is closed."""


PRINTABLE = frozenset(range(0x20, 0x7F)) | frozenset(b"\t\n\r")


def ascii_text(data: bytes) -> str:
    """The bytes as text; ProtocolError for a byte that is not printable ASCII or white space
    (the protocol has no other)."""
    bad = next((byte for byte in data if byte not in PRINTABLE), None)
    if bad is not None:
        raise ProtocolError(f"byte 0x{bad:02X} is not ASCII text: not the socketcand protocol")
    return data.decode("ascii")


def split_commands(buffer: str) -> tuple[list[str], str]:
    """Complete ``< … >`` commands in ``buffer`` (stripped of the brackets) and the rest.

    ProtocolError for anything else: text outside the brackets other than white space (an HTTP
    request line, say: a web page's POST must not get its body read as commands), a ``<`` inside
    a command, or an unfinished command longer than any valid one.
    """
    commands: list[str] = []
    while True:
        start = buffer.find("<")
        outside = buffer if start < 0 else buffer[:start]
        if outside.strip():
            raise ProtocolError(
                f"{outside.strip().splitlines()[0][:40]!r} outside < >: not the socketcand protocol"
            )
        if start < 0:
            return commands, ""
        end = buffer.find(">", start)
        inner = buffer[start + 1 : end if end >= 0 else len(buffer)]
        if "<" in inner:
            raise ProtocolError("'<' inside a command: not the socketcand protocol")
        if end < 0:
            if len(inner) >= MAX_COMMAND_CHARS:
                raise ProtocolError(f"a command longer than {MAX_COMMAND_CHARS} characters")
            return commands, buffer[start:]
        commands.append(inner.strip())
        buffer = buffer[end + 1 :]


def parse_send(command: str) -> SendRequest:
    """The frame in ``send ID LEN B0 B1 …`` (hex fields); FrameError if it is malformed."""
    words = command.split()
    if len(words) < 3 or words[0] != "send":
        raise FrameError(f"not a send command: {command!r}")
    try:
        arbitration_id, length = int(words[1], 16), int(words[2], 16)
        data = bytes(int(word, 16) for word in words[3:])
    except ValueError:
        raise FrameError(f"send command with a field that is not hex: {command!r}") from None
    extended = len(words[1]) > 3
    limit = 0x1FFFFFFF if extended else 0x7FF
    if not 0 <= arbitration_id <= limit or length != len(data) or length > 8:
        raise FrameError(f"send command with a bad id or length: {command!r}")
    return SendRequest(arbitration_id, data, extended)
