"""A small tmpfs of the test's own, for full-disk and read-only tests on a real filesystem.

Mounting needs root (CI runs as root); elsewhere the tests that need one skip with a line that
says so. `fill` takes every free block, as a full disk does; `read_only` remounts it read-only.
"""

from __future__ import annotations

import contextlib
import errno
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

SIZE = "256k"
NR_INODES = 64
SKIP_REASON = "needs root to mount a small tmpfs (CI runs as root): full-disk tests skipped"


def free_bytes(folder: Path) -> int:
    status = os.statvfs(folder)
    return status.f_bavail * status.f_frsize


@contextlib.contextmanager
def small_tmpfs(where: Path, size: str = SIZE) -> Iterator[Path]:
    """A fresh tmpfs of `size` mounted at `where` (made if missing), unmounted afterwards."""
    where.mkdir(parents=True, exist_ok=True)
    options = f"size={size},nr_inodes={NR_INODES},mode=0755"
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
        capture_output=True,
        text=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"{SKIP_REASON} ({mounted.stderr.strip()})")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def fill(folder: Path, *, inodes: bool = False, leave_bytes: int = 0) -> None:
    """Take every free block of the filesystem under `folder` but `leave_bytes`, as a disk
    filling up does (with `inodes`, every free inode too: no file can even be made)."""
    filler = folder / ".filler"
    descriptor = os.open(filler, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    try:
        for size in (1 << 20, 4096, 1):  # large pieces, then whatever is left
            with contextlib.suppress(OSError):
                while os.write(descriptor, b"\0" * size):
                    pass
        if leave_bytes:
            os.ftruncate(descriptor, max(os.fstat(descriptor).st_size - leave_bytes, 0))
    finally:
        os.close(descriptor)
    for index in range(NR_INODES if inodes else 0):
        try:
            (folder / f".inode-{index}").touch()
        except OSError as error:
            if error.errno == errno.ENOSPC:
                return
            raise


def read_only(folder: Path) -> None:
    """Remount the tmpfs at `folder` read-only."""
    subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True)


def entries(folder: Path) -> set[str]:
    """The names in `folder`, fillers left out."""
    return {name for name in os.listdir(folder) if not name.startswith((".filler", ".inode-"))}
