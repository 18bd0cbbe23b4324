"""The Foxglove server turns away web pages: a connection whose `Origin` header names a site not
allowed gets 403 and never reaches the SDK's server; a client without one (a program, the desktop
app, the dashboard) and an allowed origin are served, the WebSocket negotiated by the SDK."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Origin, Subprotocol

from bywire.loopback import Endpoint
from bywire.telemetry.capture import Capture
from bywire.telemetry.origin_gate import origin_of
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.writer import TelemetryWriter

FOXGLOVE_APP = "https://app.foxglove.dev"
SUBPROTOCOLS = [Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1")]
LIMIT_S = 10.0


@pytest.fixture
def url() -> Iterator[str]:
    writer = TelemetryWriter(Outbox[Capture](10))
    port = writer.serve(Endpoint("127.0.0.1", 0), (FOXGLOVE_APP,))
    try:
        yield f"ws://127.0.0.1:{port}"
    finally:
        writer.close()


def _server_info(url: str, origin: str | None) -> str:
    """The first message the server sends a client that got in (its serverInfo)."""
    with connect(
        url,
        subprotocols=SUBPROTOCOLS,
        origin=None if origin is None else Origin(origin),
        open_timeout=LIMIT_S,
    ) as client:
        first = client.recv(timeout=LIMIT_S)
        return first if isinstance(first, str) else first.decode()


@pytest.mark.parametrize("origin", [None, FOXGLOVE_APP, FOXGLOVE_APP + "/"])
def test_a_client_that_is_no_page_or_an_allowed_page_is_served(
    url: str, origin: str | None
) -> None:
    assert '"op":"serverInfo"' in _server_info(url, origin).replace(" ", "")


@pytest.mark.parametrize(
    "origin", ["https://evil.example", "http://app.foxglove.dev", "null", "http://127.0.0.1:8080"]
)
def test_a_page_of_any_other_origin_gets_403(url: str, origin: str) -> None:
    with pytest.raises(InvalidStatus) as refusal:
        _server_info(url, origin)
    assert refusal.value.response.status_code == 403
    assert b"is not allowed" in refusal.value.response.body


def test_what_is_not_http_gets_400_and_is_closed(url: str) -> None:
    port = int(url.rsplit(":", 1)[1])
    with socket.create_connection(("127.0.0.1", port), timeout=LIMIT_S) as raw:
        raw.sendall(b"< open can0 >\r\n\r\n")
        answer = b""
        while chunk := raw.recv(4096):
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 400 Bad Request\r\n")


@pytest.mark.parametrize(
    ("head", "parsed"),
    [
        (b"GET / HTTP/1.1\r\nHost: x\r\nOrigin: https://a.b", (True, "https://a.b")),
        (b"GET / HTTP/1.1\r\nHost: x", (True, None)),
        (b"GET / HTTP/1.1\r\norigin:https://a.b", (True, "https://a.b")),
        (b"GET / HTTP/1.1\r\nOrigin: https://a.b\r\nOrigin: https://c.d", (False, "https://a.b")),
        (b"GET /\r\nOrigin: x", (False, None)),
        (b"\xff / HTTP/1.1", (False, None)),
    ],
)
def test_the_origin_header_is_read_as_http_has_it(
    head: bytes, parsed: tuple[bool, str | None]
) -> None:
    assert origin_of(head) == parsed
