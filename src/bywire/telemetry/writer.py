"""The consumer of the feed: a thread that turns captures into messages and hands them to sinks.

On virtual time it runs in the controller's process; on real time in a process of its own
(`writer_process`), where the interpreter time it takes is no time the loop can wait for.

Sinks are foxglove-sdk's: an MCAP file (`open_mcap`) and the Foxglove WebSocket server
(`start_server`), both bound to one `foxglove.Context` that holds a channel per topic with its
JSON Schema. The SDK writes files and serves clients in its own threads, outside the interpreter
lock; this thread only encodes. It yields the lock after each message, so the loop waits at most
one message's encoding (tens of µs) for it, not the interpreter's 5 ms switch interval.
"""

from __future__ import annotations

import contextlib
import json
import sys
import threading
import time
from pathlib import Path

import foxglove
from foxglove.websocket import WebSocketServer

from bywire.background import OWNER
from bywire.errors import ConfigError
from bywire.loopback import Endpoint, ListenAddress
from bywire.priority import leave_realtime
from bywire.telemetry.capture import Capture
from bywire.telemetry.foxglove_topics import FoxgloveTopics
from bywire.telemetry.mcap_file import CHUNK_BYTES, McapFile
from bywire.telemetry.messages import message
from bywire.telemetry.origin_gate import OriginGate
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.schemas import SCHEMAS

INTERNAL_HOST = "127.0.0.1"  # where the SDK's own server listens, behind the gate
POLL_S = 0.05  # how long the writer waits for a capture before looking at `closed` again


class TelemetryWriter:
    """Encodes every capture of `outbox` onto the channels of its own foxglove Context.

    `log_offset_s` is added to the controller's clock for the log times: the epoch offset of the
    run's start (so Foxglove shows wall time: on virtual time the run's wall-clock start plus the
    simulated seconds).
    """

    def __init__(self, outbox: Outbox[Capture], *, log_offset_s: float = 0.0) -> None:
        self._outbox = outbox
        # In whole nanoseconds: an epoch time in float seconds is only good to ~0.2 µs.
        self._log_offset_ns = round(log_offset_s * 1e9)
        self.context = foxglove.Context()
        self._channels = {
            topic: foxglove.Channel(topic, schema=schema, context=self.context)
            for topic, schema in SCHEMAS.items()
        }
        self._foxglove_topics = FoxgloveTopics(self.context)  # log, flags, decoded CAN, pose
        self._mcap: foxglove.MCAPWriter | None = None
        self._file: McapFile | None = None
        self.mcap_failure: str | None = None
        """Why the recording stopped early (a full disk, a failed write), once it has."""
        self._server: WebSocketServer | None = None
        self._gate: OriginGate | None = None
        self._thread: threading.Thread | None = None
        self.written = 0
        """Captures written."""
        self.messages = 0
        """Messages logged for them (a capture may add one to a Foxglove topic as well)."""

    def record(self, path: Path) -> None:
        """Write every channel to an MCAP file at `path` (overwritten if it exists), through a
        file that keeps space ahead and never fails the SDK (`mcap_file`)."""
        try:
            self._file = McapFile(path)
            options = foxglove.mcap.MCAPWriteOptions(chunk_size=CHUNK_BYTES)
            self._mcap = foxglove.open_mcap(
                self._file, context=self.context, writer_options=options
            )
        except Exception as error:  # OSError, or the SDK's own types for I/O failures
            self._close_file()
            raise ConfigError(f"cannot write the MCAP file {path}: {error}") from None

    def serve(self, endpoint: Endpoint | ListenAddress, origins: tuple[str, ...] = ()) -> int:
        """Serve every channel to Foxglove WebSocket clients; returns the port it listens on.

        The SDK's server listens on a loopback port of its own, behind an `OriginGate` on
        `endpoint` that turns away web pages of any origin but `origins` and lets clients that
        offer the older subprotocol name in too (`subprotocols`)."""
        try:
            self._server = foxglove.start_server(
                name="bywire", host=INTERNAL_HOST, port=0, context=self.context
            )
            self._gate = OriginGate(
                endpoint.host, endpoint.port, (INTERNAL_HOST, self._server.port), origins
            )
        except Exception as error:  # e.g. the port is taken
            if self._server is not None:
                self._server.stop()
            raise ConfigError(f"cannot serve Foxglove on {endpoint}: {error}") from None
        return self._gate.port

    def start(self) -> TelemetryWriter:
        self._thread = OWNER.thread(self._drain, name="bywire-telemetry", stop=self._outbox.close)
        return self

    def close(self, timeout_s: float = 5.0) -> None:
        """Write what is queued, then close the file and stop the server."""
        self._outbox.close()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join(timeout_s)
        if self._mcap is not None:
            self._mcap.close()
        self._close_file()
        if self._gate is not None:
            self._gate.close()
        if self._server is not None:
            self._server.stop()

    def _drain(self) -> None:
        leave_realtime()  # looking never competes with the loop at its priority
        outbox = self._outbox
        while True:
            captures = outbox.take(POLL_S)
            if not captures and outbox.closed:
                return
            for capture in captures:
                self.write(capture)
                time.sleep(0)  # let the loop's thread take the interpreter lock if it waits

    def write(self, capture: Capture) -> None:
        """Encode one capture onto its channel (the writer's thread, or a test, calls this)."""
        topic, body = message(capture)
        log_time_ns = self._log_offset_ns + round(capture.time_s * 1e9)
        data = json.dumps(body, separators=(",", ":")).encode()
        self._channels[topic].log(data, log_time=log_time_ns)
        self.messages += 1 + self._foxglove_topics.write(capture, log_time_ns)
        self.written += 1
        if self._file is not None and (self._file.full or self._file.error is not None):
            self._stop_recording(self._file)

    def _stop_recording(self, file: McapFile) -> None:
        """The disk is full (or a write failed): finish the file here and say so, once."""
        if self._mcap is not None:
            with contextlib.suppress(Exception):  # nothing it raises may end the live feed
                self._mcap.close()
            self._mcap = None
        self._close_file()
        self._file = None  # nothing more goes to it, and nothing more is said
        if file.error is None:
            self.mcap_failure = (
                f"{file.path}: the disk is full: recording stopped after {self.messages}"
                " messages; the file is a complete MCAP up to there"
            )
        else:
            self.mcap_failure = (
                f"{file.path}: cannot write ({file.error.strerror or file.error}): recording"
                f" stopped after {self.messages} messages; the file ends at the failure"
            )
        print(f"bywire telemetry: {self.mcap_failure}", file=sys.stderr, flush=True)

    def _close_file(self) -> None:
        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
