"""Atomic replacement on a real filesystem: a full disk (no block, or no inode, left) and a
read-only one leave the old file and nothing else, however often a write is tried; a writer
killed by SIGKILL at any moment leaves the old file or the new one, whole, and at most one
temporary file, which the next write removes."""

from __future__ import annotations

import errno
import random
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.atomic_file import remove_leftovers, temporaries, write_atomically
from tests.tmpfs import entries, fill, read_only, small_tmpfs

ATTEMPTS = 1000  # a controller retrying every pass for 10 s would try about as often
KILLS = 60
WRITER = """
import sys
from pathlib import Path
from bywire.atomic_file import remove_leftovers, write_atomically
target, size = Path(sys.argv[1]), int(sys.argv[2])
remove_leftovers(target)
print("ready", flush=True)
for index in range(10**9):
    write_atomically(target, bytes([65 + index % 26]) * size)
"""


@pytest.fixture
def disk(tmp_path: Path) -> Iterator[Path]:
    with small_tmpfs(tmp_path / "disk") as folder:
        yield folder


@pytest.mark.parametrize("inodes", [False, True], ids=["no-block-left", "no-inode-left"])
def test_a_full_disk_leaves_the_old_file_and_nothing_else(disk: Path, inodes: bool) -> None:
    target = disk / "state.json"
    write_atomically(target, b"old")
    fill(disk, inodes=inodes)
    for _ in range(ATTEMPTS):
        with pytest.raises(OSError, match="No space left on device") as failure:
            write_atomically(target, b"new" * 2000)
        assert failure.value.errno == errno.ENOSPC
    assert target.read_bytes() == b"old"
    assert entries(disk) == {"state.json"}  # before the fix: one temporary file per attempt


def test_a_read_only_disk_leaves_the_old_file_and_nothing_else(disk: Path) -> None:
    target = disk / "state.json"
    write_atomically(target, b"old")
    read_only(disk)
    for _ in range(ATTEMPTS // 10):
        with pytest.raises(OSError, match="Read-only file system") as failure:
            write_atomically(target, b"new")
        assert failure.value.errno == errno.EROFS
    assert target.read_bytes() == b"old"
    assert entries(disk) == {"state.json"}


def test_an_exception_mid_write_removes_the_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "state.json"
    write_atomically(target, b"old")

    def interrupted(_descriptor: int) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr("os.fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_atomically(target, b"new")
    assert target.read_bytes() == b"old"
    assert temporaries(target) == []


def test_a_writer_killed_at_any_moment_leaves_a_whole_file_and_one_leftover_at_most(
    tmp_path: Path,
) -> None:
    target, size = tmp_path / "state.json", 256 << 10  # large enough to be killed mid-write
    write_atomically(target, b"Z" * size)
    generator = random.Random(33)
    leftovers_seen = 0
    for _ in range(KILLS):
        writer = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(target), str(size)],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert writer.stdout is not None
        assert writer.stdout.readline() == "ready\n"  # it removed the last one's leftover
        assert len(temporaries(target)) <= 1  # the one it writes now, if any
        time.sleep(generator.uniform(0.0, 0.05))
        writer.send_signal(signal.SIGKILL)
        writer.wait()
        writer.stdout.close()
        data = target.read_bytes()
        assert len(data) == size
        assert data == data[:1] * size  # one whole version, never a mix
        left = temporaries(target)
        assert len(left) <= 1
        leftovers_seen += len(left)
    assert remove_leftovers(target) <= 1
    write_atomically(target, b"after")
    assert temporaries(target) == []
    print(f"{leftovers_seen} of {KILLS} kills left a temporary file; the next writer removed it")
