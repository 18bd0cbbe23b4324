"""The telemetry writer in a process of its own, for a controller on real time.

Encoding a state message takes ~80 µs of interpreter time. In the controller's process, a loop
that woke while the writer thread encoded waited for the interpreter lock, and the feed cost the
loop's latency p99 ~0.16 ms (bench/RESULTS.md, runs M and N). Here no thread of the controller's
process works for the feed: the loop itself ships (`ship`, called after its passes by the tap),
every `SHIP_PERIOD_S`: it takes at most `SHIP_BATCH` captures from the outbox, dumps them with
`marshal` (`wire`, a few µs) and writes them to a non-blocking pipe. The child process builds the
messages and owns foxglove-sdk: the MCAP file and the WebSocket server.

- **Start:** the child opens its sinks and answers one JSON line on its stdout: the server's port,
  or the error that names what could not open (raised here as `ConfigError`).
- **A stuck or dead child** costs the loop nothing: a full pipe refuses the write at once, the
  frame waits for the next ship, and meanwhile the outbox drops its oldest captures, counted; a
  broken pipe ends the shipping.
- **End:** `close` writes what is left (waiting at most its timeout) and closes the pipe: that is
  the child's signal to write what it has, close the file and stop the server. The child ignores
  SIGINT, SIGTERM and SIGHUP (a Ctrl-C or a service stop reaches the whole group) and lives in its
  own session, so the controller decides when the feed ends; and when the controller dies, even by
  SIGKILL, the kernel closes the pipe and the MCAP file is still finished. A child still finishing
  after `close` is waited for at the end of the command by bywire's owner of background work
  (`bywire.background`), which closes the pipe of one never closed, and kills one that has not
  ended within the time the child gives itself to finish (`CHILD_CLOSE_S`), naming it.

On virtual time there is no loop time to protect, and the writer stays a thread (`feed`), so that
a recording is complete and the same on every machine.
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import IO, TYPE_CHECKING

from bywire.background import OWNER
from bywire.errors import ConfigError
from bywire.loopback import Endpoint, ListenAddress
from bywire.priority import leave_realtime
from bywire.telemetry.capture import Capture
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.wire import WireError, pack, split, unpack

if TYPE_CHECKING:
    from bywire.telemetry.writer import TelemetryWriter

START_TIMEOUT_S = 30.0  # the child imports foxglove-sdk and opens its sinks: ~0.2 s here
SHIP_PERIOD_S = 0.01  # the loop ships at most this often: batches, not a write per frame
SHIP_BATCH = 256  # captures per ship at most (bounds the loop's cost: ~0.1 ms for CAN frames)
PIPE_BYTES = 1 << 20  # asked of the kernel (an unprivileged process may have up to 1 MiB)
CHILD_POLL_S = 0.02  # how long the child sleeps when the pipe is empty
READ_BYTES = 1 << 16
CHILD_QUEUE = 4096  # captures the child holds while it encodes; more waits in the pipe
WRITER_NICENESS = 10  # as the dashboard's view: looking yields to everything else
CHILD_CLOSE_S = 10.0  # after the pipe closes, how long the child may take to finish the file


class WriterProcess:
    """A writer process fed from `outbox`; `port` is its Foxglove server's, if it serves.

    `ship(now)` is for the loop, after a pass; `close` for the end of the run.
    """

    def __init__(
        self,
        outbox: Outbox[Capture],
        *,
        mcap_path: Path | None,
        foxglove: Endpoint | ListenAddress | None,
        log_offset_s: float,
        start_timeout_s: float = START_TIMEOUT_S,
        origins: tuple[str, ...] = (),
    ) -> None:
        self._outbox = outbox
        offset_ns = round(log_offset_s * 1e9)
        command = [sys.executable, "-m", __name__, "--log-offset-ns", str(offset_ns)]
        if mcap_path is not None:
            command += ["--mcap", str(mcap_path)]
        if foxglove is not None:
            command += ["--host", foxglove.host, "--port", str(foxglove.port)]
            command += [f"--origin={origin}" for origin in origins]
        # Ended by closing its pipe (it ignores the stop signals), then killed if it has not
        # finished its file within the time it gives itself to.
        self._process = OWNER.popen(
            command,
            name="bywire-telemetry-writer",
            stop=self._close_pipe,
            grace_s=CHILD_CLOSE_S + 1.0,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            start_new_session=True,
        )
        assert self._process.stdin is not None
        assert self._process.stdout is not None
        self._pipe: IO[bytes] = self._process.stdin
        try:
            port = _answer(self._process, self._process.stdout, start_timeout_s)
        except BaseException:
            self._process.kill()
            self._process.wait()
            raise
        finally:
            self._process.stdout.close()  # the child says nothing after its answer
        self._fd = self._pipe.fileno()
        with contextlib.suppress(OSError):  # a smaller pipe only means fewer captures in flight
            fcntl.fcntl(self._fd, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
        os.set_blocking(self._fd, False)
        self.port = port
        self.pid = self._process.pid
        self.broken = False  # the child has gone: nothing more is shipped
        self._unsent = memoryview(b"")  # the rest of a frame the pipe had no room for
        self._next_ship_s = float("-inf")

    def ship(self, now: float) -> None:
        """From the loop: every `SHIP_PERIOD_S`, write what the pipe takes; never waits."""
        if now < self._next_ship_s or self.broken:
            return
        self._next_ship_s = now + SHIP_PERIOD_S
        if self._frame_to_send():
            self._write()

    @property
    def unsent_bytes(self) -> int:
        """What a full pipe left of the last frame, waiting for the next ship."""
        return len(self._unsent)

    def close(self, timeout_s: float = 5.0) -> None:
        """Write what is queued, close the pipe and wait up to `timeout_s` for the child to finish
        the file. A child still finishing is left to do so (it exits once it has); one that does
        not read within the time loses what it has not read."""
        deadline = time.monotonic() + timeout_s
        self._outbox.close()
        while not self.broken and time.monotonic() < deadline and self._frame_to_send():
            select.select([], [self._fd], [], max(deadline - time.monotonic(), 0.0))
            self._write()
        self._close_pipe()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self._process.wait(max(deadline - time.monotonic(), 0.0))

    def _close_pipe(self) -> None:
        with contextlib.suppress(OSError):  # a broken pipe has nothing left to flush
            if self._process.stdin is not None:
                self._process.stdin.close()

    def _frame_to_send(self) -> bool:
        """Whether a frame waits to be written: the rest of the last one, or a new one packed
        from at most `SHIP_BATCH` queued captures."""
        if not self._unsent:
            captures = self._outbox.take_ready(SHIP_BATCH)
            if captures:
                self._unsent = memoryview(pack(captures))
        return bool(self._unsent)

    def _write(self) -> None:
        try:
            written = os.write(self._fd, self._unsent)
        except BlockingIOError:  # the pipe is full: the frame waits, the outbox drops
            return
        except OSError:  # the child has gone: nothing more can reach the sinks
            self.broken = True
            self._unsent = memoryview(b"")
            return
        self._unsent = self._unsent[written:]


def _answer(process: subprocess.Popen[bytes], stdout: IO[bytes], timeout_s: float) -> int | None:
    """The child's start-up answer: its server's port, or a ConfigError with its reason."""
    readable, _, _ = select.select([stdout], [], [], timeout_s)
    line = stdout.readline() if readable else b""
    if not line:
        code = process.poll()
        state = "did not answer" if code is None else f"exited with code {code}"
        raise ConfigError(
            f"the telemetry writer process {state} within {timeout_s:g} s; its error, if any, is"
            " above"
        )
    answer = json.loads(line)
    if "error" in answer:
        process.wait()
        raise ConfigError(str(answer["error"]))
    port: int | None = answer["port"]
    return port


def serve_pipe(fd: int, writer: TelemetryWriter, outbox: Outbox[Capture]) -> int:
    """The child's work: every capture of every frame on the pipe `fd`, queued for `writer`,
    until the pipe closes; then the writer finishes. The number of captures read.

    The pipe is read without waiting: when it is empty the child sleeps `CHILD_POLL_S`. A reader
    asleep on the pipe would make every write of the loop wake it (on a VM, an interrupt to the
    other CPU: ~15 µs of the loop's time per write); one asleep on a timer costs the loop nothing.
    """
    os.set_blocking(fd, False)
    buffer = bytearray()
    count = 0
    try:
        while True:
            try:
                chunk = os.read(fd, READ_BYTES)
            except BlockingIOError:
                time.sleep(CHILD_POLL_S)
                continue
            if not chunk:  # the controller closed the pipe, or died
                break
            buffer += chunk
            for payload in split(buffer):
                for capture in unpack(payload):
                    outbox.put(capture)
                    count += 1
    except WireError as error:
        print(f"bywire telemetry writer: {error}; the feed ends here", file=sys.stderr)
    finally:
        writer.close(CHILD_CLOSE_S)
    return count


def _step_aside() -> None:
    """Run behind the controller: under SCHED_BATCH, which the kernel never lets preempt a running
    task when it wakes (its poll timer wakes it 50 times a second, on the loop's CPU as often as
    not), and at niceness `WRITER_NICENESS`. Its threads inherit both."""
    leave_realtime()
    with contextlib.suppress(AttributeError, OSError):  # not Linux
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
    with contextlib.suppress(OSError):
        os.nice(WRITER_NICENESS)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m bywire.telemetry.writer_process",
        description="The telemetry writer of a bywire controller on real time: reads captures"
        " from stdin (started by the controller, not by hand).",
    )
    parser.add_argument("--log-offset-ns", type=int, default=0)
    parser.add_argument("--mcap", type=Path)
    parser.add_argument("--host")
    parser.add_argument("--port", type=int)
    parser.add_argument("--origin", action="append", default=[])
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    for stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(stop, signal.SIG_IGN)  # the controller ends the feed by closing the pipe
    _step_aside()
    # Here, not at the top: the controller imports this module for `WriterProcess` and must not
    # load the writer's foxglove (a 39 MB native core, locked whole with `lock_memory`).
    from bywire.telemetry.writer import TelemetryWriter  # noqa: PLC0415

    outbox: Outbox[Capture] = Outbox(CHILD_QUEUE, wait_when_full=True)
    writer = TelemetryWriter(outbox, log_offset_s=args.log_offset_ns / 1e9)
    port = None
    try:
        if args.mcap is not None:
            writer.record(args.mcap)
        if args.host is not None:
            port = writer.serve(ListenAddress(args.host, args.port), tuple(args.origin))
    except ConfigError as error:
        writer.close(0.0)
        print(json.dumps({"error": str(error)}), flush=True)
        return 2
    writer.start()
    print(json.dumps({"port": port}), flush=True)
    serve_pipe(sys.stdin.fileno(), writer, outbox)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
