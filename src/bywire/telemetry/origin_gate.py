"""The Foxglove server's door: a web page's connection is let in only from an allowed origin.

A browser lets any page it shows open a WebSocket to any address, loopback included, and says which
page it is only in the handshake's `Origin` header. foxglove-sdk's server does not look at it, so it
listens on loopback port of its own and this gate listens where the user asked: it reads each
connection's HTTP request head, answers `403 Forbidden` and closes when the `Origin` header names an
origin that is not allowed (none is, unless configured: Foxglove's web app is
`https://app.foxglove.dev`), or `400` when the head is not HTTP, and otherwise hands the connection
to the SDK's server byte for byte (the SDK negotiates the subprotocol, the gate never reads the
WebSocket), but for one rename: a client that offers only the older subprotocol name
`foxglove.websocket.v1` (Foxglove Studio before the SDK, Lichtblick) has it offered as the SDK's
`foxglove.sdk.v1`, and the server's choice named back (`subprotocols`). A client without an `Origin`
header (the Foxglove desktop app, `bywire dashboard`, any program) is no web page and goes through.
At most `MAX_CONNECTIONS` at once.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterable

from bywire.accepting import Slots, accepted
from bywire.background import OWNER
from bywire.telemetry.subprotocols import rename_choice, rename_offer

HEAD_LIMIT_BYTES = 16 << 10
HEAD_TIMEOUT_S = 5.0
MAX_CONNECTIONS = 32
ACCEPT_POLL_S = 0.1
RELAY_BYTES = 1 << 16


def origin_of(head: bytes) -> tuple[bool, str | None]:
    """(well formed, the Origin header's value or None) of an HTTP request head."""
    try:
        lines = head.decode("ascii").split("\r\n")
    except UnicodeDecodeError:
        return False, None
    request = lines[0].split(" ")
    if len(request) != 3 or not request[2].startswith("HTTP/"):
        return False, None
    origins = [
        value.strip()
        for name, _, value in (line.partition(":") for line in lines[1:] if line)
        if name.strip().lower() == "origin"
    ]
    return len(origins) <= 1, (origins[0] if origins else None)


class OriginGate:
    """Listens on (host, port) and passes each allowed connection to `target` (host, port)."""

    def __init__(
        self, host: str, port: int, target: tuple[str, int], allowed: Iterable[str] = ()
    ) -> None:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, port), family=family)
        self._listener.settimeout(ACCEPT_POLL_S)
        self._target = target
        self.allowed = frozenset(origin.rstrip("/").lower() for origin in allowed)
        self.refused = 0
        """Connections turned away: a web page of another origin, not HTTP, too many."""
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._sockets: set[socket.socket] = set()
        self._slots = Slots(MAX_CONNECTIONS)
        self._thread = OWNER.thread(
            self._accept_loop, name="bywire-origin-gate", stop=self._stopping.set
        )

    @property
    def port(self) -> int:
        return int(self._listener.getsockname()[1])

    def close(self) -> None:
        """Stop accepting and end every connection."""
        self._stopping.set()
        self._thread.join(timeout=5.0)
        self._listener.close()
        with self._lock:
            sockets = list(self._sockets)
        for sock in sockets:
            _close(sock)

    def _accept_loop(self) -> None:
        for sock in accepted(self._listener, self._stopping):
            if not self._slots.take():
                self._answer(sock, 503, "too many connections")
                continue
            OWNER.thread(self._pass, sock, name="bywire-origin-gate-pass", stop=self.close)

    def _pass(self, client: socket.socket) -> None:
        upstream = None
        try:
            head = _read_head(client)
            well_formed, origin = origin_of(head.partition(b"\r\n\r\n")[0])
            if not well_formed or b"\r\n\r\n" not in head:
                self._answer(client, 400, "not an HTTP request")
                return
            if origin is not None and origin.rstrip("/").lower() not in self.allowed:
                self._answer(client, 403, f"origin {origin[:100]} is not allowed")
                return
            upstream = socket.create_connection(self._target)
            with self._lock:
                self._sockets |= {client, upstream}
            head, renamed = rename_offer(head)
            upstream.sendall(head)
            if renamed:
                client.sendall(rename_choice(_read_head(upstream)))
            back = OWNER.thread(
                _relay, upstream, client, name="bywire-origin-gate-relay", stop=self.close
            )
            _relay(client, upstream)
            back.join()
        except OSError:
            pass
        finally:
            self._slots.give()
            with self._lock:
                self._sockets -= {client, upstream}
            _close(client)
            if upstream is not None:
                _close(upstream)

    def _answer(self, sock: socket.socket, status: int, reason: str) -> None:
        self.refused += 1
        text = {400: "Bad Request", 403: "Forbidden", 503: "Service Unavailable"}[status]
        body = f"bywire telemetry: {reason}\n".encode("ascii", "replace")
        head = (
            f"HTTP/1.1 {status} {text}\r\nContent-Type: text/plain\r\n"
            f"Content-Length: {len(body)}\r\nConnection: close\r\n\r\n"
        )
        with contextlib.suppress(OSError):
            sock.settimeout(1.0)
            sock.sendall(head.encode("ascii") + body)
        _close(sock)


def _read_head(sock: socket.socket) -> bytes:
    """The bytes up to the end of the HTTP head (and whatever came with them)."""
    deadline_s = time.monotonic() + HEAD_TIMEOUT_S
    data = b""
    while b"\r\n\r\n" not in data and len(data) <= HEAD_LIMIT_BYTES:
        left_s = deadline_s - time.monotonic()
        if left_s <= 0:
            break
        sock.settimeout(left_s)
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
    return data


def _relay(source: socket.socket, sink: socket.socket) -> None:
    """Copy `source` to `sink` until `source` ends; then end `sink`'s sending side."""
    source.settimeout(None)
    with contextlib.suppress(OSError):
        while chunk := source.recv(RELAY_BYTES):
            sink.sendall(chunk)
    with contextlib.suppress(OSError):
        sink.shutdown(socket.SHUT_WR)


def _close(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):
        sock.shutdown(socket.SHUT_RDWR)
    sock.close()
