"""The writer in a process of its own (real time), fed by the loop's `ship`: it records what the
in-process writer records; a sink that cannot open is refused with its reason; a writer that stops
reading or dies never holds the loop; and the file is finished even when the controller is
killed."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from bywire.background import OWNER
from bywire.errors import ConfigError
from bywire.loopback import Endpoint
from bywire.telemetry.capture import CanCapture, Capture
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.schemas import SCHEMAS
from bywire.telemetry.wire import pack
from bywire.telemetry.writer import TelemetryWriter
from bywire.telemetry.writer_process import WriterProcess, serve_pipe

WAIT_S = 30.0  # generous: only a hang reaches it

Recorded = list[tuple[str, int, bytes]]


def read_mcap(path: Path, *, every: bool = False) -> Recorded:
    """The feed's own JSON topics (one message a capture), or `every` topic (Foxglove's too)."""
    with path.open("rb") as stream:
        return [
            (channel.topic, message.log_time, message.data)
            for _s, channel, message in make_reader(stream).iter_messages()
            if every or channel.topic in SCHEMAS
        ]


def _frames(count: int) -> list[Capture]:
    return [CanCapture(k * 1e-3, 0x100 + k % 16, bytes(8), "other") for k in range(count)]


def _wait_until(condition: object, what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():  # type: ignore[operator]
        assert time.monotonic() < deadline, f"still waiting for {what}"
        time.sleep(0.01)


def _gone(pid: int) -> bool:
    """The process has exited (reaped, or a zombie no one has reaped yet)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return True
    return state in {"Z", "X"}


def test_the_process_records_exactly_what_the_thread_records(
    tmp_path: Path, captures: list[Capture]
) -> None:
    """Same captures, same offset: the same messages at the same log times on the same topics."""
    offset_s = 1_700_000_000.25
    in_thread = tmp_path / "thread.mcap"
    writer = TelemetryWriter(Outbox(1), log_offset_s=offset_s)
    writer.record(in_thread)
    for capture in captures:
        writer.write(capture)
    writer.close()

    in_process = tmp_path / "process.mcap"
    outbox: Outbox[Capture] = Outbox(len(captures))
    process = WriterProcess(outbox, mcap_path=in_process, foxglove=None, log_offset_s=offset_s)
    for capture in captures:  # as the loop does: queue, and ship after every pass
        outbox.put(capture)
        process.ship(capture.time_s)
    assert outbox.dropped == 0
    process.close(WAIT_S)  # writes the rest

    assert _gone(process.pid)
    assert len(read_mcap(in_process)) == len(captures)
    recorded = read_mcap(in_process, every=True)
    assert recorded == read_mcap(in_thread, every=True)


def test_a_file_that_cannot_be_written_is_refused_with_its_path(tmp_path: Path) -> None:
    missing = tmp_path / "no-such-folder" / "feed.mcap"
    with pytest.raises(ConfigError, match=r"cannot write the MCAP file .*no-such-folder"):
        WriterProcess(Outbox(4), mcap_path=missing, foxglove=None, log_offset_s=0.0)


def test_a_port_in_use_is_refused_with_the_address() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(ConfigError, match=f"cannot serve Foxglove on 127.0.0.1:{port}"):
            WriterProcess(
                Outbox(4), mcap_path=None, foxglove=Endpoint("127.0.0.1", port), log_offset_s=0.0
            )


def test_a_writer_that_stops_reading_never_holds_the_loop_and_still_finishes(
    tmp_path: Path,
) -> None:
    """The writer process is frozen (SIGSTOP): the pipe fills, the loop's ship finds no room and
    returns at once, and the outbox drops its oldest captures; `close` gives up after its time.
    Thawed, the writer reads what the pipe holds, sees it closed and finishes the file."""
    path = tmp_path / "frozen.mcap"
    capacity = 1000
    outbox: Outbox[Capture] = Outbox(capacity)
    process = WriterProcess(outbox, mcap_path=path, foxglove=None, log_offset_s=0.0)
    os.kill(process.pid, signal.SIGSTOP)

    def loop() -> None:
        now = 0.0
        for capture in _frames(200_000):  # far more than a 1 MiB pipe holds
            outbox.put(capture)
            now += 1e-3
            process.ship(now)  # returns at once: the pipe does not wait

    try:
        passes = threading.Thread(target=loop, daemon=True)
        passes.start()
        passes.join(WAIT_S)
        assert not passes.is_alive(), "the loop was held by a writer that does not read"
        assert process.unsent_bytes > 0  # a frame waits for room
        assert outbox.dropped > 0
        assert len(outbox) == capacity
        process.close(0.2)
        assert not _gone(process.pid)  # left to finish: never killed with the file open
    finally:
        os.kill(process.pid, signal.SIGCONT)
    _wait_until(lambda: _gone(process.pid), "the thawed writer to finish")
    recorded = read_mcap(path)  # a finished file: the reader needs its summary and footer
    assert 0 < len(recorded) <= outbox.put_count - outbox.dropped


def test_a_writer_that_dies_costs_the_loop_nothing() -> None:
    outbox: Outbox[Capture] = Outbox(100)
    process = WriterProcess(outbox, mcap_path=None, foxglove=None, log_offset_s=0.0)
    os.kill(process.pid, signal.SIGKILL)
    now = 0.0

    def one_pass() -> bool:
        nonlocal now
        outbox.put(_frames(1)[0])
        now += 1.0
        process.ship(now)
        return process.broken

    _wait_until(one_pass, "the broken pipe")
    for capture in _frames(1000):
        outbox.put(capture)
        now += 1.0
        process.ship(now)  # nothing is shipped any more: the outbox keeps the newest
    assert len(outbox) == 100
    assert outbox.dropped >= 900
    process.close(WAIT_S)


CONTROLLER = """
import sys, time
from pathlib import Path
from bywire.telemetry.capture import CanCapture
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.writer_process import WriterProcess

outbox = Outbox(100_000)
process = WriterProcess(outbox, mcap_path=Path(sys.argv[1]), foxglove=None, log_offset_s=0.0)
for k in range(5000):
    outbox.put(CanCapture(k * 1e-3, 0x123, bytes([k % 256]), "other"))
now = 0.0
while len(outbox) or process.unsent_bytes:
    now += 1.0
    process.ship(now)
print(process.pid, flush=True)
time.sleep(3600)
"""


def test_the_file_is_finished_when_the_controller_is_killed(tmp_path: Path) -> None:
    """SIGKILL leaves the controller no last word: the kernel closes the pipe, and the writer
    takes that as the end of the feed, so the MCAP holds every capture shipped and is readable."""
    path = tmp_path / "killed.mcap"
    controller = subprocess.Popen(
        [sys.executable, "-c", CONTROLLER, str(path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert controller.stdout is not None
        writer_pid = int(controller.stdout.readline())
    finally:
        controller.kill()
        controller.wait()
    _wait_until(lambda: _gone(writer_pid), "the writer to finish after the controller died")
    recorded = read_mcap(path)
    assert len(recorded) == 5000
    assert {topic for topic, _, _ in recorded} == {"/bywire/can"}


def test_a_corrupt_stream_ends_the_feed_with_what_came_before(
    capsys: pytest.CaptureFixture[str],
) -> None:
    good = pack(_frames(3))
    outbox: Outbox[Capture] = Outbox(16, wait_when_full=True)
    writer = TelemetryWriter(outbox).start()
    read_end, write_end = os.pipe()
    os.write(write_end, good + (8).to_bytes(4, "little") + b"\x00garbage")
    os.close(write_end)
    try:
        assert serve_pipe(read_end, writer, outbox) == 3
    finally:
        os.close(read_end)
    assert "not a frame of captures" in capsys.readouterr().err
    assert writer.written == 3  # what came before the corruption was written, then it closed
    assert outbox.closed


def test_the_owner_ends_a_writer_left_open_and_its_file_is_finished(tmp_path: Path) -> None:
    """Issue 42: a run that ends without closing the feed (an exception past its `finally`, a
    test that failed midway) leaves the writer to the owner, which closes its pipe (the writer
    ignores the stop signals): the child ends, with every shipped capture in a finished file."""
    path = tmp_path / "left.mcap"
    outbox: Outbox[Capture] = Outbox(1000)
    since = OWNER.mark()
    process = WriterProcess(outbox, mcap_path=path, foxglove=None, log_offset_s=0.0)
    now = 0.0
    for capture in _frames(500):
        outbox.put(capture)
    while len(outbox) or process.unsent_bytes:
        now += 1.0
        process.ship(now)
    assert [work.name for work in OWNER.running() if work.number > since] == [
        "bywire-telemetry-writer"
    ]
    assert OWNER.end_all(since) == []
    assert _gone(process.pid)
    assert len(read_mcap(path)) == 500
