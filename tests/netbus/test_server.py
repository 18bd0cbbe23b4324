"""The socketcand server with python-can's own socketcand client on the other end."""

from __future__ import annotations

import queue
import socket
import time
from collections.abc import Callable, Iterator

import can
import pytest

from bywire.loopback import Endpoint
from bywire.netbus.server import SocketcandServer
from bywire.netbus.socketcand import SendRequest

TIMEOUT_S = 10.0  # generous: only a broken server takes this long


def wait_for(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.005)


@pytest.fixture
def server() -> Iterator[SocketcandServer]:
    with SocketcandServer(Endpoint("127.0.0.1", 0)) as served:
        yield served


def connect(server: SocketcandServer, clients: int = 1) -> can.BusABC:
    host, port = server.address
    bus = can.Bus(interface="socketcand", host=host, port=port, channel="can0")
    wait_for(lambda: server.client_count >= clients, "the client to reach raw mode")
    return bus


def receive(bus: can.BusABC, count: int) -> list[can.Message]:
    messages: list[can.Message] = []
    deadline = time.monotonic() + TIMEOUT_S
    while len(messages) < count and time.monotonic() < deadline:
        message = bus.recv(0.1)
        if message is not None:
            messages.append(message)
    return messages


def test_a_client_gets_every_published_frame_in_order(server: SocketcandServer) -> None:
    bus = connect(server)
    try:
        for index in range(300):
            server.publish(0x200 + index % 6, 1000.0 + index / 1000, bytes([index % 256, 1]))
        messages = receive(bus, 300)
    finally:
        bus.shutdown()
    assert [(m.arbitration_id, m.data[0]) for m in messages] == [
        (0x200 + i % 6, i % 256) for i in range(300)
    ]
    assert messages[1].timestamp == pytest.approx(1000.001)


def test_a_clients_frames_reach_the_inbox_tagged_with_its_number(server: SocketcandServer) -> None:
    bus = connect(server)
    try:
        bus.send(can.Message(arbitration_id=0x101, data=b"\x01\x02\x03", is_extended_id=False))
        number, request = server.inbox.get(timeout=TIMEOUT_S)
    finally:
        bus.shutdown()
    assert number >= 1
    assert request == SendRequest(0x101, b"\x01\x02\x03", False)


def test_a_client_does_not_get_its_own_frames_back(server: SocketcandServer) -> None:
    first, second = connect(server), connect(server, clients=2)
    try:
        first.send(can.Message(arbitration_id=0x7F0, data=b"\x01", is_extended_id=False))
        origin, request = server.inbox.get(timeout=TIMEOUT_S)
        server.publish(request.arbitration_id, 1.0, request.data, origin=origin)
        server.publish(0x7F1, 1.0, b"")
        assert [m.arbitration_id for m in receive(second, 2)] == [0x7F0, 0x7F1]
        assert [m.arbitration_id for m in receive(first, 1)] == [0x7F1]
    finally:
        first.shutdown()
        second.shutdown()


def test_another_channel_is_refused(server: SocketcandServer) -> None:
    host, port = server.address
    with pytest.raises(can.CanError, match="error"):
        can.Bus(interface="socketcand", host=host, port=port, channel="vcan7")


def test_closing_sends_what_is_queued_then_disconnects(server: SocketcandServer) -> None:
    bus = connect(server)
    try:
        for index in range(50):
            server.publish(0x300, float(index), bytes([index]))
        server.close()
        assert len(receive(bus, 50)) == 50
    finally:
        bus.shutdown()


def test_a_client_that_never_finishes_the_handshake_is_harmless(server: SocketcandServer) -> None:
    with socket.create_connection(server.address) as raw:
        assert raw.recv(64) == b"< hi >"
        raw.sendall(b"< open can0 >")
        assert raw.recv(64) == b"< ok >"
    server.publish(0x200, 0.0, b"")  # nobody in raw mode: nothing to send, nothing breaks
    assert server.client_count == 0
    with pytest.raises(queue.Empty):
        server.inbox.get_nowait()
