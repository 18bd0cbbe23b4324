"""The dashboard's side of the telemetry feed: a Foxglove WebSocket client in a thread.

It connects to the feed of `bywire run` or `bywire sim --realtime --foxglove`, subscribes to
`/bywire/state` and `/bywire/events`, and keeps the newest state and the last events for the
view to read. It is only a client: if it is slow the server drops messages for it, and if it
stops the controller never knows.
"""

from __future__ import annotations

import collections
import json
import struct
import threading
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

from bywire.background import OWNER
from bywire.telemetry.schemas import EVENTS_TOPIC, STATE_TOPIC

# The SDK's server speaks protocol v1 under the first name; older servers under the second.
SUBPROTOCOLS = [Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1")]
MESSAGE_DATA = 0x01  # binary opcode: u8 op, u32 subscription id, u64 log time, payload
HEADER = struct.Struct("<BIQ")
STATE_ID, EVENTS_ID, OTHER_ID = 1, 2, 100  # subscription ids: other topics from 100 on
OPEN_TIMEOUT_S = 5.0
CLOSE_TIMEOUT_S = 0.5  # a closing handshake the server does not answer this soon is given up
EVENTS_KEPT = 50


class FeedClient:
    """The newest `/bywire/state` message and the last events of the feed at `url`."""

    def __init__(self, url: str, *, topics: tuple[str, ...] = (STATE_TOPIC, EVENTS_TOPIC)) -> None:
        self.url = url
        self._topics = topics
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None
        self._events: collections.deque[dict[str, Any]] = collections.deque(maxlen=EVENTS_KEPT)
        self._status = f"connecting to {url}"
        self._ended = False
        self._answered = threading.Event()  # live, or ended before it ever was
        self._live = False
        self.received = 0
        self._connection: ClientConnection | None = None
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> FeedClient:
        self._thread = OWNER.thread(self._follow, name="bywire-feed", stop=self.close)
        return self

    def close(self) -> None:
        """Close the connection with a handshake, also one still being opened."""
        self._closing.set()
        connection = self._connection
        if connection is not None:
            connection.close()
        if self._thread is not None:
            self._thread.join(OPEN_TIMEOUT_S)

    def latest(self) -> dict[str, Any] | None:
        with self._lock:
            return self._state

    def events(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._events)

    @property
    def status(self) -> str:
        with self._lock:
            return self._status

    @property
    def ended(self) -> bool:
        """The feed has gone (the controller stopped, or it was never there)."""
        with self._lock:
            return self._ended

    def wait_live(self, timeout_s: float = 2 * OPEN_TIMEOUT_S + 1.0) -> str | None:
        """Wait until the feed is live (None) or has failed before it ever was: why, in one
        line. Bounded: the connection and the channel advertisement each time out."""
        if not self._answered.wait(timeout_s):
            return f"no answer from {self.url} within {timeout_s:g} s"
        with self._lock:
            return None if self._live else self._status

    def _set_status(self, status: str, *, ended: bool = False, live: bool = False) -> None:
        with self._lock:
            self._status = status
            self._ended = ended
            self._live = self._live or live
        if live or ended:
            self._answered.set()

    def _follow(self) -> None:
        try:
            with connect(
                self.url,
                subprotocols=SUBPROTOCOLS,
                open_timeout=OPEN_TIMEOUT_S,
                close_timeout=CLOSE_TIMEOUT_S,
                max_size=None,
            ) as connection:
                self._connection = connection
                if self._closing.is_set():  # closed while it was being opened
                    connection.close()
                self._subscribe(connection)
                # Short: the title bar shows it after the source, within 80 columns.
                self._set_status("live feed", live=True)
                for data in connection:
                    if isinstance(data, bytes) and data and data[0] == MESSAGE_DATA:
                        self._take(data)
                    elif isinstance(data, str):
                        self._subscribe_new(connection, data)
        except ConnectionClosed:
            self._set_status("feed ended", ended=True)
        except (OSError, InvalidHandshake, InvalidURI, TimeoutError) as error:
            self._set_status(f"no feed at {self.url}: {_reason(error)}", ended=True)
        else:
            self._set_status("feed ended", ended=True)

    def _subscribe(self, connection: ClientConnection) -> None:
        """Read the server's JSON messages up to the channel advertisement, then subscribe."""
        while True:
            text = connection.recv(timeout=OPEN_TIMEOUT_S)
            if isinstance(text, str) and self._subscribe_new(connection, text):
                return

    def _subscribe_new(self, connection: ClientConnection, text: str) -> bool:
        body = json.loads(text)
        if body.get("op") != "advertise":
            return False
        ids = {STATE_TOPIC: STATE_ID, EVENTS_TOPIC: EVENTS_ID}
        wanted = [
            {"id": ids.get(channel["topic"], OTHER_ID + index), "channelId": channel["id"]}
            for index, channel in enumerate(body["channels"])
            if channel["topic"] in self._topics
        ]
        if wanted:
            connection.send(json.dumps({"op": "subscribe", "subscriptions": wanted}))
        return bool(wanted)

    def _take(self, data: bytes) -> None:
        _op, subscription, _log_time_ns = HEADER.unpack_from(data)
        body = json.loads(data[HEADER.size :])
        with self._lock:
            self.received += 1
            if subscription == STATE_ID:
                self._state = body
            elif subscription == EVENTS_ID:
                self._events.append(body)


def _reason(error: Exception) -> str:
    """The OS's words without Python's [Errno n], or the handshake's own."""
    if isinstance(error, OSError) and error.strerror:
        return error.strerror.lower()
    return str(error) or type(error).__name__
