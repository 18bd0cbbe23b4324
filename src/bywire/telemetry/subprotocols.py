"""Older Foxglove clients and the SDK's server: one subprotocol renamed in the handshake.

foxglove-sdk's WebSocket server accepts only the subprotocol `foxglove.sdk.v1` (and `.v1.1`), so
Foxglove Studio before the SDK and Lichtblick, which offer `foxglove.websocket.v1`, got HTTP 400
(issue 32, defect 8). Both names stand for the same protocol (v1 of Foxglove's WebSocket
protocol), so the server's door (`origin_gate.OriginGate`, where the user asked it to listen)
renames the offer in the client's upgrade request to `foxglove.sdk.v1` and the server's choice
back in its answer, and otherwise copies bytes both ways untouched: every other header reaches
the SDK's server as the client sent it, and no frame is decoded.

    client ── GET, offers foxglove.websocket.v1 ──▶ gate ── GET, offers foxglove.sdk.v1 ──▶ SDK
    client ◀─ 101, chose foxglove.websocket.v1 ─── gate ◀─ 101, chose foxglove.sdk.v1 ──── SDK
"""

from __future__ import annotations

import re

SDK = "foxglove.sdk.v1"
OLDER = "foxglove.websocket.v1"
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
