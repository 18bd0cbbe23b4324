"""`bywire sim` writing its files to a disk that is full (a real tmpfs): each file that cannot be
written whole is one line, the run and its summary go on, and the file opens in its readers up
to where the disk filled. Before, a CAN log gave an OSError traceback and no summary, and the
MCAP writer flooded stderr with one SDK error per message."""

from __future__ import annotations

import contextlib
import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import pytest
from mcap.reader import make_reader

from bywire.canlog.read import read_log
from bywire.cli.main import main
from bywire.hal.tape.run_record import read_record
from tests.tmpfs import fill, small_tmpfs

LEFT_BYTES = 48 << 10  # a few hundred frames' worth
RUN = ("sim", "--duration", "10", "--json")


@pytest.fixture
def disk(tmp_path: Path) -> Iterator[Path]:
    with small_tmpfs(tmp_path / "disk", "16m") as folder:
        yield folder


def _sim(*argv: str) -> tuple[int, dict[str, Any], str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([*RUN, *argv])
    return status, json.loads(out.getvalue()), err.getvalue()


@pytest.mark.parametrize("suffix", [".asc", ".log", ".blf"])
def test_a_can_log_on_a_full_disk_stops_in_one_line_and_reads_to_there(
    disk: Path, suffix: str
) -> None:
    path = disk / f"bus{suffix}"
    fill(disk, leave_bytes=LEFT_BYTES // 8 if suffix == ".blf" else LEFT_BYTES)  # BLF compresses
    status, summary, err = _sim("--log", str(path))
    assert status == 1  # the run passed, but the log is not all there
    assert summary["passed"] is True
    assert summary["simulated_s"] == 10.0
    (failure,) = summary["file_errors"]
    assert failure.startswith(f"{path}: cannot write (No space left on device): the CAN log")
    assert err == f"bywire sim: error: {failure}\n"
    read = sum(1 for _ in can.LogReader(path))  # python-can's own reader, to the end
    assert read > 100
    assert len(read_log(path).messages) == read


def test_a_run_record_on_a_full_disk_stops_in_one_line_and_reads_to_there(disk: Path) -> None:
    path = disk / "run.jsonl"
    fill(disk, leave_bytes=LEFT_BYTES)
    status, summary, err = _sim("--record", str(path))
    assert status == 1
    assert summary["passed"] is True
    (failure,) = summary["file_errors"]
    assert "No space left on device: the record keeps the whole lines" in failure
    assert err.count("\n") == 1
    assert len(read_record(path).outputs) > 100


def test_an_mcap_on_a_full_disk_stops_once_and_is_a_complete_file(disk: Path) -> None:
    path = disk / "run.mcap"
    fill(disk, leave_bytes=LEFT_BYTES)
    status, summary, err = _sim("--mcap", str(path))
    assert status == 0  # the recording is the feed's: it says so itself, the run is as it was
    assert summary["passed"] is True
    assert err.count("\n") == 1, err
    assert f"bywire telemetry: {path}: the disk is full: recording stopped after" in err
    with path.open("rb") as file:
        assert sum(1 for _ in make_reader(file).iter_messages()) >= 1
