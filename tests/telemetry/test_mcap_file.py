"""The MCAP recording on a disk that fills up or fails: one line says so, the feed goes on, no
flood, and the file is a complete MCAP up to the point the disk filled (a real tmpfs)."""

from __future__ import annotations

import contextlib
import errno
import io
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader

from bywire.telemetry.capture import Capture
from bywire.telemetry.mcap_file import RESERVE_BYTES, STEP_BYTES, McapFile
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.writer import TelemetryWriter
from tests.tmpfs import fill, free_bytes, small_tmpfs

DISK = "64m"


@pytest.fixture
def disk(tmp_path: Path) -> Iterator[Path]:
    with small_tmpfs(tmp_path / "disk", DISK) as folder:
        yield folder


def _writer() -> TelemetryWriter:
    return TelemetryWriter(Outbox[Capture](10))


def _write_until(writer: TelemetryWriter, captures: list[Capture], limit: int) -> int:
    """Write the captures over and over (later in time) until the recording stops or `limit`
    messages went out; the count at the stop."""
    for index in range(limit):
        capture = captures[index % len(captures)]
        shift = (index // len(captures)) * 10.0
        writer.write(capture._replace(time_s=capture.time_s + shift))
        if writer.mcap_failure is not None:
            return writer.messages
    raise AssertionError(f"the recording never stopped in {limit} messages")


def _messages(path: Path) -> int:
    with path.open("rb") as file:
        return sum(1 for _ in make_reader(file).iter_messages())


def test_a_disk_that_fills_up_ends_the_recording_complete_with_one_line(
    disk: Path, captures: list[Capture], capsys: pytest.CaptureFixture[str]
) -> None:
    fill(disk, leave_bytes=RESERVE_BYTES + STEP_BYTES + (2 << 20))  # 2 MiB of data fit first
    path = disk / "run.mcap"
    writer = _writer()
    writer.record(path)
    stopped_at = _write_until(writer, captures, 200_000)
    for capture in captures:  # the feed goes on (the server's clients still get it)
        writer.write(capture)
    writer.close()
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # once, whatever came after
    assert f"bywire telemetry: {path}: the disk is full: recording stopped after" in err
    assert "complete MCAP" in err
    with path.open("rb") as file:
        reader = make_reader(file)
        summary = reader.get_summary()  # indexed: summary and footer are there
        assert summary is not None
        assert summary.statistics is not None
        assert summary.statistics.message_count == stopped_at
    assert _messages(path) == stopped_at
    assert free_bytes(disk) > 0  # the space kept ahead was given back


def test_a_disk_that_fails_mid_recording_stops_it_once_and_the_data_before_reads(
    tmp_path: Path,
    captures: list[Capture],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    path = tmp_path / "run.mcap"
    writer = _writer()
    writer.record(path)
    for capture in captures * 30:  # some 20 chunks on the disk
        writer.write(capture)
    real_write = os.pwrite

    def failing_disk(descriptor: int, data: bytes, offset: int) -> int:  # I/O errors from now
        if descriptor == writer_fd:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real_write(descriptor, data, offset)

    writer_fd = _descriptor_of(path)
    monkeypatch.setattr(os, "pwrite", failing_disk)
    stopped_at = _write_until(writer, captures, 200_000)
    for capture in captures:
        writer.write(capture)
    monkeypatch.undo()
    writer.close()
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "cannot write (Input/output error): recording stopped after" in err
    read = 0
    with path.open("rb") as file:  # what reached the disk reads, record by record
        records = StreamReader(file, skip_magic=False, emit_chunks=False).records
        with contextlib.suppress(McapError):  # up to the chunk the failure cut
            for record in records:
                read += isinstance(record, Message)
    assert stopped_at // 2 < read < stopped_at


def _descriptor_of(path: Path) -> int:
    """This process's descriptor open on `path` (the MCAP file's)."""
    for name in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):
            if os.readlink(f"/proc/self/fd/{name}") == str(path):
                return int(name)
    raise AssertionError(f"{path} is not open")


def test_the_sdk_sees_no_failure_so_it_logs_none(disk: Path) -> None:
    file = McapFile(disk / "x.mcap")
    fill(disk)
    assert file.write(b"x" * (RESERVE_BYTES + STEP_BYTES + (1 << 20))) > 0
    assert file.error is not None or file.full
    assert file.write(b"more") == 4  # reported written, dropped
    file.close()


def test_the_writer_prints_nothing_while_the_disk_has_room(
    tmp_path: Path, captures: list[Capture]
) -> None:
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        writer = _writer()
        writer.record(tmp_path / "run.mcap")
        for capture in captures:
            writer.write(capture)
        writer.close()
    assert err.getvalue() == ""
    assert writer.mcap_failure is None
    assert _messages(tmp_path / "run.mcap") == writer.messages >= len(captures)
