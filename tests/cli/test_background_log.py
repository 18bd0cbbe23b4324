"""`bywire run`'s log handler: lines reach the descriptor in order, held lines wait for
`resume`, and a reader that never reads blocks the writer thread, never the caller."""

from __future__ import annotations

import contextlib
import logging
import os
import threading
from collections.abc import Iterator

import pytest

from bywire.cli.background_log import BackgroundLog

LIMIT_S = 30.0  # a deadlock guard, never a timing figure


@pytest.fixture
def pipe() -> Iterator[tuple[int, int]]:
    read_fd, write_fd = os.pipe()
    yield read_fd, write_fd
    for fd in (read_fd, write_fd):
        with contextlib.suppress(OSError):
            os.close(fd)


@pytest.fixture
def opened() -> Iterator[list[BackgroundLog]]:
    """The handlers a test makes, closed after it: their writer threads end."""
    handlers: list[BackgroundLog] = []
    yield handlers
    for handler in handlers:
        handler.close()


def _logger(handler: logging.Handler, name: str) -> logging.Logger:
    logger = logging.getLogger(name)
    logger.propagate = False
    logger.handlers = [handler]
    logger.setLevel(logging.INFO)
    return logger


def _read_lines(fd: int, count: int) -> list[str]:
    data = b""
    while data.count(b"\n") < count:
        data += os.read(fd, 65536)
    return data.decode().splitlines()


def test_lines_from_several_threads_all_arrive_and_the_handler_lock_is_free(
    pipe: tuple[int, int], opened: list[BackgroundLog]
) -> None:
    read_fd, write_fd = pipe
    handler = BackgroundLog(write_fd)
    opened.append(handler)
    logger = _logger(handler, "bywire.test.threads")

    def write_lines(n: int) -> None:
        for i in range(50):
            logger.info("t%d %d", n, i)

    threads = [threading.Thread(target=write_lines, args=(n,)) for n in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(LIMIT_S)
    assert handler.drain(LIMIT_S)
    lines = _read_lines(read_fd, 200)
    assert sorted(lines) == sorted(f"t{n} {i}" for n in range(4) for i in range(50))
    # logging.Handler's own lock is released after every record (a method named `release`
    # on the handler once shadowed it, and the next thread to log waited for ever).
    assert handler.lock is not None
    assert handler.lock.acquire(blocking=False)
    handler.lock.release()


def test_held_lines_wait_for_resume_and_keep_their_order(
    pipe: tuple[int, int], opened: list[BackgroundLog]
) -> None:
    read_fd, write_fd = pipe
    handler = BackgroundLog(write_fd)
    opened.append(handler)
    logger = _logger(handler, "bywire.test.hold")
    handler.hold()
    logger.info("first")
    handler.write_raw(b"raw\n")
    logger.info("second")
    assert not handler.drain(0.0)  # nothing written while held
    os.set_blocking(read_fd, False)
    with pytest.raises(BlockingIOError):
        os.read(read_fd, 1)
    os.set_blocking(read_fd, True)
    handler.resume()
    assert handler.drain(LIMIT_S)
    assert _read_lines(read_fd, 3) == ["first", "raw", "second"]


def test_a_reader_that_never_reads_never_blocks_the_caller(
    pipe: tuple[int, int], opened: list[BackgroundLog]
) -> None:
    _read_fd, write_fd = pipe
    handler = BackgroundLog(write_fd, capacity=100)
    opened.append(handler)
    logger = _logger(handler, "bywire.test.frozen")
    line = "x" * 1000
    done = threading.Event()

    def flood() -> None:
        for _ in range(1000):  # 1 MB: far more than a pipe holds
            logger.info(line)
        done.set()

    caller = threading.Thread(target=flood, daemon=True)
    caller.start()
    assert done.wait(LIMIT_S), "a log call blocked on a full pipe"
    assert not handler.drain(0.05)  # the writer thread is the one stuck on the pipe
