"""Reading a small text file a user named, and refusing in one line what is not one.

A robot file, a scenario, a key or a freshness file is read whole. Named by mistake (or on
purpose), `/dev/zero` would fill the memory, a FIFO would hang the reader before it read a byte,
a directory or a 2 GB log would give a traceback. Here the file is opened without waiting
(`O_NONBLOCK`: opening a FIFO returns at once), refused unless it is a regular file, read up to a
limit, and decoded as strict UTF-8: every failure is a `ConfigError` naming the file and what is
wrong with it, which the command line prints as one line (exit 2).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from bywire.errors import ConfigError

DEFAULT_LIMIT_BYTES = 1 << 20  # 1 MiB: a robot file or a scenario is a few KiB


def open_regular(path: Path, what: str) -> int:
    """A descriptor open for reading on `path`, once it is known to be a regular file (closed
    again and ConfigError otherwise). The caller closes it."""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such {what}") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot read {what}: {_reason(error)}") from None
    try:
        mode = os.fstat(descriptor).st_mode
        if not stat.S_ISREG(mode):
            raise ConfigError(f"{path}: {what} is {_kind(mode)}, not a regular file")
        os.set_blocking(descriptor, True)
    except BaseException:
        os.close(descriptor)
        raise
    return descriptor


def check_regular(path: Path, what: str) -> None:
    """ConfigError (one line) unless `path` is a regular file, for a file read as a stream
    (a run record): a FIFO or a device is refused before anything opens it."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such {what}") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot read {what}: {_reason(error)}") from None
    if not stat.S_ISREG(mode):
        raise ConfigError(f"{path}: {what} is {_kind(mode)}, not a regular file")


def read_text(path: Path, what: str, limit_bytes: int = DEFAULT_LIMIT_BYTES) -> str:
    """The whole of `path` as UTF-8 text; ConfigError (one line) when it cannot be that: missing,
    unreadable, not a regular file, larger than `limit_bytes`, or not UTF-8."""
    descriptor = open_regular(path, what)
    try:
        with os.fdopen(descriptor, "rb") as file:
            data = file.read(limit_bytes + 1)
    except OSError as error:
        raise ConfigError(f"{path}: cannot read {what}: {_reason(error)}") from None
    if len(data) > limit_bytes:
        raise ConfigError(f"{path}: {what} is larger than {_size(limit_bytes)}: refused")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ConfigError(f"{path}: not UTF-8 text (byte {error.start})") from None


def _reason(error: OSError) -> str:
    if error.errno == errno.EISDIR:
        return "it is a directory"
    return error.strerror or str(error)


def _kind(mode: int) -> str:
    kinds = (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((name for test, name in kinds if test(mode)), "not a plain file")


def _size(limit_bytes: int) -> str:
    if limit_bytes >= 1 << 20 and limit_bytes % (1 << 20) == 0:
        return f"{limit_bytes >> 20} MiB"
    if limit_bytes >= 1 << 10 and limit_bytes % (1 << 10) == 0:
        return f"{limit_bytes >> 10} KiB"
    return f"{limit_bytes} bytes"
