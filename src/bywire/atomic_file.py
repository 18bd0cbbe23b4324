"""Replacing a small file atomically, leaving nothing behind whatever happens.

A reader sees the old file or the new one, never a mix: the data goes to a temporary file in the
same folder (`.NAME.tmp-XXXXXXXX`), is flushed to the disk (fsync) and renamed over the old one;
the folder is synced so that the rename itself survives a power cut. On every error (a full disk,
a read-only filesystem, a failed fsync, an exception of any kind) the temporary file is removed
before the `OSError` reaches the caller, and the old file is as it was. Only a process killed
mid-write (SIGKILL, a power cut) can leave one: `remove_leftovers`, which the writer calls before
each write, deletes it, so there is never more than one, and none once the next write is done.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path

TEMPORARY_MARK = ".tmp-"


def write_atomically(path: Path, data: bytes, mode: int = 0o600) -> None:
    """Replace `path` with `data` (file mode `mode`); OSError when it cannot, `path` unchanged."""
    temporary, descriptor = _new_temporary(path, mode)
    try:
        try:
            os.fchmod(descriptor, mode)  # whatever the umask
            view = memoryview(data)
            while view:
                view = view[os.write(descriptor, view) :]
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise
    _sync_folder(path.parent)


def temporaries(path: Path) -> list[Path]:
    """The temporary files of `path` in its folder (a write under way, or a killed one's)."""
    with contextlib.suppress(OSError):
        return sorted(path.parent.glob(f".{path.name}{TEMPORARY_MARK}*"))
    return []


def remove_leftovers(path: Path) -> int:
    """Delete the temporary files a killed writer of `path` left; how many. The one writer of
    `path` calls it before it writes."""
    removed = 0
    for leftover in temporaries(path):
        with contextlib.suppress(OSError):
            leftover.unlink()
            removed += 1
    return removed


def _new_temporary(path: Path, mode: int) -> tuple[Path, int]:
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC
    while True:
        temporary = path.with_name(f".{path.name}{TEMPORARY_MARK}{secrets.token_hex(4)}")
        try:
            return temporary, os.open(temporary, flags, mode)
        except FileExistsError:
            continue


def _sync_folder(folder: Path) -> None:
    """Make the rename durable where the OS allows (some filesystems refuse fsync on a folder)."""
    with contextlib.suppress(OSError):
        descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
