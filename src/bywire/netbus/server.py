"""A socketcand server on loopback: python-can, cantools and can.viewer clients share one bus.

Threads: one accepts connections; each client has a reader (handshake, then its ``send``
commands, which go to ``inbox`` tagged with the client's number) and, once in raw mode, a writer
that drains the client's bounded outbox. ``publish`` may be called from any thread (the
simulator's): it only enqueues, so a slow or stalled client never holds up the bus; when a
client's outbox is full its frames are dropped and counted.

Loopback is not a wall: any web page in a browser on this machine can open a connection to it
(an HTTP POST whose body reads as socketcand commands). So the server takes nothing but the
protocol: from the first byte a client sends, anything that is not printable ASCII inside
``< >`` (an HTTP request line, a byte above 0x7F) gets one ``< error … >`` line and the
connection closed, before any command of it is acted on. At most `MAX_CONNECTIONS` clients are
served at once (two threads each), and one that has not reached raw mode within
`HANDSHAKE_S` is closed: idle connections cannot pile up threads. Counted in `refused`.
"""

from __future__ import annotations

import contextlib
import itertools
import queue
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from bywire.accepting import Slots, accepted
from bywire.background import OWNER
from bywire.errors import ConfigError, FrameError
from bywire.loopback import Endpoint
from bywire.netbus import socketcand

CHANNEL = "can0"
OUTBOX_FRAMES = 10_000  # 30 s of the robot's traffic
SOCKET_TIMEOUT_S = 0.5  # how often idle readers look at the stop flag; a send may block this long
ACCEPT_POLL_S = 0.1  # how often the accepting thread looks at the stop flag
# python-can's client reads each handshake reply with a single recv(): frames must not share
# the TCP segment of the final "< ok >", so they start flowing a moment after it.
HANDSHAKE_SETTLE_S = 0.05
MAX_CONNECTIONS = 16  # clients at once: python-can, cantools, bywire monitor, a few more
HANDSHAKE_S = 5.0  # from connecting to raw mode: python-can takes a few ms
_STOP = None


@dataclass(eq=False)
class _Client:
    number: int
    sock: socket.socket
    outbox: queue.Queue[str | None] = field(default_factory=lambda: queue.Queue(OUTBOX_FRAMES))
    dropped: int = 0
    writing: bool = False  # a writer thread owns the socket's sending side and closes it


class SocketcandServer:
    """Serves one CAN channel over the socketcand protocol on a loopback endpoint.

    ``inbox`` receives ``(client number, SendRequest)`` for every frame a client sends.
    ``publish(…, origin=n)`` sends a frame to every client in raw mode except client ``n``.
    """

    def __init__(
        self,
        endpoint: Endpoint,
        channel: str = CHANNEL,
        *,
        max_connections: int = MAX_CONNECTIONS,
        handshake_s: float = HANDSHAKE_S,
    ) -> None:
        family = socket.AF_INET6 if ":" in endpoint.host else socket.AF_INET
        try:
            self._listener = socket.create_server((endpoint.host, endpoint.port), family=family)
        except OSError as error:
            raise ConfigError(f"cannot listen on {endpoint}: {error.strerror}") from error
        self._listener.settimeout(ACCEPT_POLL_S)
        self.channel = channel
        self.inbox: queue.SimpleQueue[tuple[int, socketcand.SendRequest]] = queue.SimpleQueue()
        self.dropped_frames = 0
        self.refused = 0
        """Connections closed for not speaking the protocol, over the limit, or too slow."""
        self._slots = Slots(max_connections)
        self._handshake_s = handshake_s
        self._clients: list[_Client] = []
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._numbers = itertools.count(1)
        self._threads: list[threading.Thread] = []
        self._spawn(self._accept_loop, "socketcand-accept")

    @property
    def address(self) -> tuple[str, int]:
        """The (host, port) the server listens on: the real port when 0 was asked for."""
        host, port = self._listener.getsockname()[:2]
        return str(host), int(port)

    @property
    def client_count(self) -> int:
        """Clients in raw mode, receiving frames."""
        with self._lock:
            return len(self._clients)

    def publish(
        self, arbitration_id: int, timestamp_s: float, data: bytes, origin: int = 0
    ) -> None:
        """Send a frame to every client in raw mode but ``origin``; never blocks."""
        line = socketcand.frame_line(arbitration_id, timestamp_s, data, arbitration_id > 0x7FF)
        with self._lock:
            clients = list(self._clients)
        for client in clients:
            if client.number == origin:
                continue
            try:
                client.outbox.put_nowait(line)
            except queue.Full:
                client.dropped += 1
                self.dropped_frames += 1

    def close(self) -> None:
        """Stop accepting, send every client what is already queued, then disconnect them."""
        self._stopping.set()
        with self._lock:
            clients = list(self._clients)
        for client in clients:
            client.outbox.put(_STOP)
        with self._lock:
            threads = list(self._threads)
        for thread in threads:
            thread.join(timeout=2 * SOCKET_TIMEOUT_S + 1.0)
        self._listener.close()

    def __enter__(self) -> SocketcandServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # --- threads ------------------------------------------------------------------------------

    def _spawn(self, target: Callable[..., None], name: str, *args: object) -> None:
        thread = OWNER.thread(target, *args, name=f"bywire-{name}", stop=self.close)
        with self._lock:  # the ended ones go: a long run serves many short connections
            self._threads = [*(t for t in self._threads if t.is_alive()), thread]

    def _accept_loop(self) -> None:
        for sock in accepted(self._listener, self._stopping):
            sock.settimeout(SOCKET_TIMEOUT_S)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            if not self._slots.take():
                self._refuse(sock, f"too many connections ({self._slots.limit} at most)")
                continue
            client = _Client(next(self._numbers), sock)
            self._spawn(self._serve, f"socketcand-client-{client.number}", client)

    def _refuse(self, sock: socket.socket, reason: str) -> None:
        """One error line and the connection closed; never waits on the client."""
        self.refused += 1
        with contextlib.suppress(OSError):
            sock.setblocking(False)
            sock.send(socketcand.error(reason).encode("ascii"))
        _close(sock)

    def _serve(self, client: _Client) -> None:
        """The client's reader: handshake, then its send commands, until it or the server ends."""
        try:
            client.sock.sendall(socketcand.HELLO.encode("ascii"))
            self._read_commands(client)
        except socketcand.ProtocolError as error:
            self.refused += 1
            line = socketcand.error(str(error))
            if client.writing:
                client.outbox.put(line)  # the writer sends it, then closes at the stop mark
            else:
                with contextlib.suppress(OSError):
                    client.sock.setblocking(False)
                    client.sock.send(line.encode("ascii"))
        except OSError:
            pass
        finally:
            self._forget(client)
            self._slots.give()
            if client.writing:
                client.outbox.put(_STOP)
            else:
                _close(client.sock)

    def _read_commands(self, client: _Client) -> None:
        buffer, state = "", "opening"
        deadline_s = time.monotonic() + self._handshake_s
        while not self._stopping.is_set():
            if state != "raw" and time.monotonic() > deadline_s:
                raise socketcand.ProtocolError(f"no raw mode within {self._handshake_s:g} s")
            try:
                chunk = client.sock.recv(4096)
            except TimeoutError:
                continue
            if not chunk:
                return
            text = socketcand.ascii_text(chunk)
            commands, buffer = socketcand.split_commands(buffer + text)
            for command in commands:
                state = self._handle(client, state, command)

    def _handle(self, client: _Client, state: str, command: str) -> str:
        """Answer one command; returns the session's next state."""
        word = command.split(" ", 1)[0]
        if state == "raw" and word == "send":
            try:
                self.inbox.put((client.number, socketcand.parse_send(command)))
            except FrameError as error:
                client.outbox.put(socketcand.error(str(error)))
            return state
        if word == "echo":
            self._reply(client, state, "< echo >")
        elif state == "opening" and command == f"open {self.channel}":
            self._reply(client, state, socketcand.OK)
            return "open"
        elif state == "open" and command == "rawmode":
            with self._lock:
                self._clients.append(client)
            client.writing = True
            self._spawn(self._write_loop, f"socketcand-writer-{client.number}", client)
            return "raw"
        else:
            message = f"cannot {command!r} here (this server offers {self.channel}, raw mode)"
            self._reply(client, state, socketcand.error(message))
        return state

    def _reply(self, client: _Client, state: str, line: str) -> None:
        if state == "raw":
            client.outbox.put(line)  # the writer owns the socket's sending side from now on
        else:
            client.sock.sendall(line.encode("ascii"))

    def _write_loop(self, client: _Client) -> None:
        """Send the client its outbox, frames batched; ends at the stop mark or a dead client."""
        try:
            client.sock.sendall(socketcand.OK.encode("ascii"))
            time.sleep(HANDSHAKE_SETTLE_S)
            while True:
                lines = [client.outbox.get()]
                while lines[-1] is not _STOP and len(lines) < 512 and not client.outbox.empty():
                    lines.append(client.outbox.get_nowait())
                text = "".join(line for line in lines if line is not _STOP)
                if text:
                    client.sock.sendall(text.encode("ascii"))
                if lines[-1] is _STOP:
                    return
        except OSError:
            return
        finally:
            self._forget(client)
            _close(client.sock)

    def _forget(self, client: _Client) -> None:
        with self._lock:
            if client in self._clients:
                self._clients.remove(client)


def _close(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):
        sock.shutdown(socket.SHUT_RDWR)
    sock.close()
