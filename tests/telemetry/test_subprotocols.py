"""The live Foxglove server takes the older subprotocol name too (issue 32, defect 8: a client
offering `foxglove.websocket.v1`, as Foxglove Studio before the SDK and Lichtblick do, got HTTP
400), through a relay that renames it and copies everything else untouched."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from websockets.sync.client import connect
from websockets.typing import Subprotocol

from bywire.loopback import Endpoint
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.schemas import STATE_TOPIC
from bywire.telemetry.subprotocols import rename_choice, rename_offer
from bywire.telemetry.writer import TelemetryWriter


@pytest.fixture
def port() -> Iterator[int]:
    writer = TelemetryWriter(Outbox(16))
    try:
        yield writer.serve(Endpoint("127.0.0.1", 0))
    finally:
        writer.close(1.0)


@pytest.mark.parametrize(
    "offered",
    [["foxglove.websocket.v1"], ["foxglove.sdk.v1"], ["foxglove.websocket.v1", "foxglove.sdk.v1"]],
)
def test_a_client_of_either_name_connects_and_sees_the_channels(
    port: int, offered: list[str]
) -> None:
    with connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=[Subprotocol(name) for name in offered],
        open_timeout=10,
        origin=None,
    ) as client:
        chosen = client.subprotocol
        messages = [json.loads(str(client.recv(timeout=10))) for _ in range(2)]
    assert chosen in offered
    assert chosen == ("foxglove.websocket.v1" if offered == ["foxglove.websocket.v1"] else chosen)
    assert messages[0]["op"] == "serverInfo"
    advertised = {channel["topic"] for channel in messages[1]["channels"]}
    assert STATE_TOPIC in advertised


def test_only_the_offer_and_the_choice_are_renamed() -> None:
    request = (
        b"GET / HTTP/1.1\r\nHost: x\r\nOrigin: http://localhost\r\n"
        b"Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n"
    )
    renamed, done = rename_offer(request)
    assert done
    assert renamed == request.replace(b"foxglove.websocket.v1", b"foxglove.sdk.v1")
    both = request.replace(b"foxglove.websocket.v1", b"foxglove.websocket.v1, foxglove.sdk.v1")
    assert rename_offer(both) == (both, False)  # the server picks the name it knows
    answer = b"HTTP/1.1 101 Switching Protocols\r\nsec-websocket-protocol: foxglove.sdk.v1\r\n\r\n"
    assert rename_choice(answer + b"\x81\x02{}") == (
        answer.replace(b"foxglove.sdk.v1", b"foxglove.websocket.v1") + b"\x81\x02{}"
    )
