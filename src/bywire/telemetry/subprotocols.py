"""Older Foxglove clients in front of the SDK's server: a TCP relay that renames one subprotocol.

foxglove-sdk's WebSocket server accepts only the subprotocol `foxglove.sdk.v1` (and `.v1.1`), so
Foxglove Studio before the SDK and Lichtblick, which offer `foxglove.websocket.v1`, got HTTP 400
(issue 32, defect 8). Both names stand for the same protocol (v1 of Foxglove's WebSocket
protocol), so the relay, listening where the user asked, renames the offer in the client's
upgrade request to `foxglove.sdk.v1` and the server's choice back in its answer, and otherwise
copies bytes both ways untouched: every other header (Origin among them) reaches the SDK's
server as the client sent it, and no frame is decoded. The SDK's server listens on loopback at a
port of its own.

    client ── GET, offers foxglove.websocket.v1 ──▶ relay ── GET, offers foxglove.sdk.v1 ──▶ SDK
    client ◀─ 101, chose foxglove.websocket.v1 ─── relay ◀─ 101, chose foxglove.sdk.v1 ──── SDK
"""

from __future__ import annotations

import contextlib
import re
import socket
import socketserver
import threading

SDK = "foxglove.sdk.v1"
OLDER = "foxglove.websocket.v1"
HEADER_END = b"\r\n\r\n"
MAX_HEADER_BYTES = 16384  # an upgrade request or answer is far smaller
CONNECT_TIMEOUT_S = 5.0
_PROTOCOL = re.compile(rb"^(sec-websocket-protocol:[ \t]*)([^\r\n]*)", re.IGNORECASE | re.MULTILINE)


def rename_offer(request: bytes) -> tuple[bytes, bool]:
    """The upgrade request with `foxglove.websocket.v1` offered as `foxglove.sdk.v1` when the
    client offers the older name only; and whether it did."""
    offered = [
        name.strip()
        for match in _PROTOCOL.finditer(request)
        for name in match.group(2).decode("latin-1").split(",")
    ]
    if OLDER not in offered or any(name.startswith(SDK) for name in offered):
        return request, False
    return _PROTOCOL.sub(lambda m: m.group(1) + SDK.encode(), request, count=1), True


def rename_choice(answer: bytes) -> bytes:
    """The server's upgrade answer with its chosen `foxglove.sdk.v1` named as the client's."""
    return _PROTOCOL.sub(lambda m: m.group(1) + OLDER.encode(), answer, count=1)


def _read_header(sock: socket.socket) -> bytes:
    data = b""
    while HEADER_END not in data and len(data) < MAX_HEADER_BYTES:
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
    return data


def _copy(source: socket.socket, target: socket.socket) -> None:
    with contextlib.suppress(OSError):
        while chunk := source.recv(65536):
            target.sendall(chunk)
    with contextlib.suppress(OSError):
        target.shutdown(socket.SHUT_WR)


class _Relay(socketserver.BaseRequestHandler):
    server: SubprotocolRelay

    def handle(self) -> None:
        client: socket.socket = self.request
        with (
            contextlib.suppress(OSError),
            socket.create_connection(self.server.upstream, timeout=CONNECT_TIMEOUT_S) as upstream,
        ):
            upstream.settimeout(None)
            request = _read_header(client)
            request, renamed = rename_offer(request)
            upstream.sendall(request)
            answer = _read_header(upstream)
            client.sendall(rename_choice(answer) if renamed else answer)
            back = threading.Thread(target=_copy, args=(upstream, client), daemon=True)
            back.start()
            _copy(client, upstream)
            back.join()


class SubprotocolRelay(socketserver.ThreadingTCPServer):
    """Listens at `listen` (host, port; port 0: any) and relays each client to `upstream`."""

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, listen: tuple[str, int], upstream: tuple[str, int]) -> None:
        self.address_family = socket.AF_INET6 if ":" in listen[0] else socket.AF_INET
        super().__init__(listen, _Relay)
        self.upstream = upstream
        self._thread = threading.Thread(
            target=self.serve_forever, name="bywire-foxglove-relay", daemon=True
        )

    @property
    def port(self) -> int:
        return int(self.server_address[1])

    def start(self) -> SubprotocolRelay:
        self._thread.start()
        return self

    def stop(self) -> None:
        self.shutdown()
        self.server_close()
