"""The socketcand server takes no stranger's word: a web page's HTTP POST whose body holds
socketcand commands injects nothing onto the bus; a non-ASCII byte is a clean refusal; idle
connections cannot pile up threads. Each stranger gets one `< error … >` line and is closed.

(Before: the POST's body was read as commands and its frame crossed the bus; a non-ASCII byte
killed the client's thread with a traceback; 300 idle connections made 303 threads.)
"""

from __future__ import annotations

import http.client
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.loopback import Endpoint
from bywire.netbus.bridge import serve_bus
from bywire.netbus.server import MAX_CONNECTIONS, SocketcandServer
from tests.netbus.test_server import TIMEOUT_S, connect, wait_for

INJECTION = b"< open can0 >< rawmode >< send 123 2 11 22 >"


@pytest.fixture
def tracebacks() -> Iterator[list[threading.ExceptHookArgs]]:
    """Every exception that ends a thread of the server (none may)."""
    seen: list[threading.ExceptHookArgs] = []
    previous = threading.excepthook
    threading.excepthook = seen.append
    try:
        yield seen
    finally:
        threading.excepthook = previous


def _answer(sock: socket.socket) -> bytes:
    """Everything the server sends until it closes the connection."""
    sock.settimeout(TIMEOUT_S)
    received = b""
    while chunk := sock.recv(4096):
        received += chunk
    return received


def test_an_http_post_to_serve_injects_nothing(
    tracebacks: list[threading.ExceptHookArgs],
) -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    with serve_bus(bus, Endpoint("127.0.0.1", 0), start_s=0.0) as bridge:
        host, port = bridge.server.address
        page = http.client.HTTPConnection(host, port, timeout=TIMEOUT_S)  # as a browser's fetch()
        page.request("POST", "/", body=INJECTION, headers={"Content-Type": "text/plain"})
        with pytest.raises((http.client.HTTPException, ConnectionError)):
            page.getresponse()  # what it gets back is no HTTP: a browser's fetch fails
        page.close()
        with socket.create_connection((host, port)) as raw:  # the same, by hand, to read it
            raw.sendall(b"POST / HTTP/1.1\r\nHost: x\r\n\r\n" + INJECTION)
            answer = _answer(raw)
        for _ in range(100):  # the bridge polls its inbox every 2 ms of the clock
            clock.advance(0.002)
    assert answer.startswith(b"< hi >< error 'POST / HTTP/1.1' outside < >: not the socketcand")
    assert answer.endswith(b" >")
    assert list(bus.log) == []  # nothing reached the bus
    assert bridge.server.refused == 2
    assert tracebacks == []


@pytest.mark.parametrize(
    "first",
    [b"\xff", "< open cän0 >".encode(), b"< open can0 >\x00", b"GET / HTTP/1.0\r\n\r\n"],
    ids=["byte-ff", "utf8", "nul", "http-get"],
)
def test_anything_but_ascii_socketcand_is_one_error_line_and_closed(
    first: bytes, tracebacks: list[threading.ExceptHookArgs]
) -> None:
    with SocketcandServer(Endpoint("127.0.0.1", 0)) as server:
        with socket.create_connection(server.address) as raw:
            raw.sendall(first + b"< open can0 >< rawmode >")
            answer = _answer(raw)
        assert answer.startswith(b"< hi >< error ")
        assert answer.count(b"< error ") == 1
        assert b"< ok >" not in answer  # refused before the open was acted on
        assert answer.decode("ascii")  # the refusal itself is ASCII
        assert server.client_count == 0
        assert server.refused == 1
    assert tracebacks == []


def test_idle_connections_cannot_pile_up_threads() -> None:
    with SocketcandServer(Endpoint("127.0.0.1", 0)) as server:
        before = threading.active_count()
        sockets = [socket.create_connection(server.address) for _ in range(300)]
        try:
            refused = sockets[MAX_CONNECTIONS:]
            for sock in refused:
                assert _answer(sock) == b"< error too many connections (16 at most) >"
            assert threading.active_count() - before <= MAX_CONNECTIONS
            assert server.refused == 300 - MAX_CONNECTIONS
        finally:
            for sock in sockets:
                sock.close()
        # Their slots come back: a real client is served again.
        wait_for(lambda: threading.active_count() <= before + 1, "the idle readers to end")
        bus = connect(server)
        bus.shutdown()


def test_a_connection_that_never_reaches_raw_mode_is_closed() -> None:
    with SocketcandServer(Endpoint("127.0.0.1", 0), handshake_s=0.3) as server:
        with socket.create_connection(server.address) as raw:
            started = time.monotonic()
            raw.sendall(b"< open can0 >")
            answer = _answer(raw)
        assert answer == b"< hi >< ok >< error no raw mode within 0.3 s >"
        assert time.monotonic() - started < TIMEOUT_S
        bus = connect(server)  # the slot is free again
        bus.shutdown()
