"""The one owner of every thread and child process bywire starts: each is started here, ended here.

In the spirit of a Trio nursery. A starter names its work and says how it is asked to stop;
`OWNER` keeps the list. `OWNER.scope()` (the `bywire` entry point holds one around every command)
ends, on every way out of it (a return, an exception, Ctrl-C; SIGTERM and SIGHUP where a command
turns them into a return), whatever was started inside it and still runs: in reverse order of
start, each with a bounded wait. A thread: its stop callback, then a join with a timeout (a thread
cannot be killed). A process: its stop callback (default SIGTERM), a grace, then SIGKILL. What did
not end is named in one line on stderr: which, and where it was started.

A starter still ends its own work first, as before (`close`, `stop`, with whatever semantics it
had); the owner is the last word on the way out, not the first. Work that has ended is forgotten.
"""

from __future__ import annotations

import builtins
import contextlib
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

THREAD_JOIN_S = 1.0  # how long an ended thread has to return after its stop callback
PROCESS_GRACE_S = 1.0  # how long a process has after its stop callback (SIGTERM) before SIGKILL
KILL_WAIT_S = 1.0  # after SIGKILL: only a process stuck in the kernel (state D) outlives this


class _Child(Protocol):
    """What the owner needs of a child process: subprocess.Popen and multiprocessing's both fit."""

    @property
    def pid(self) -> int | None: ...

    def terminate(self) -> None: ...

    def kill(self) -> None: ...


@dataclass(eq=False)
class Work:
    """One thread or child process started through the owner."""

    kind: str  # "thread" or "process"
    name: str
    started_at: str  # file:line of the starter, so that a leak names its source
    alive: Callable[[], bool]
    end: Callable[[float | None], bool]  # ask it to stop, wait its own bound or less; ended?
    # the Thread, Popen or Process itself; builtins.object: mypyc cannot load a field annotated
    # `object` at import (issue 43)
    handle: builtins.object = field(repr=False)
    number: int = 0  # in order of start, from 1: what a scope ends is numbered after its mark

    def __str__(self) -> str:
        return f"{self.kind} {self.name!r} (started at {self.started_at})"


class Owner:
    """Starts threads and child processes, and ends those still running when asked."""

    def __init__(self) -> None:
        # Re-entrant: a signal handler may start work (`bywire dashboard`'s SIGTERM closes its
        # client in a thread) while the main thread it interrupted holds the lock.
        self._lock = threading.RLock()
        self._started: list[Work] = []
        self._count = 0

    def forget_all(self) -> None:
        """In a forked child: its parent's work is not its own."""
        self._lock = threading.RLock()  # another thread may have held it at the fork
        self._started = []

    def thread(
        self,
        target: Callable[..., object],
        *args: object,
        name: str,
        stop: Callable[[], None] | None = None,
        join_s: float = THREAD_JOIN_S,
    ) -> threading.Thread:
        """Start `target(*args)` in a daemon thread named `name`; `stop` asks it to return."""
        thread = threading.Thread(target=target, args=args, name=name, daemon=True)

        def end(wait_s: float | None) -> bool:
            if stop is not None:
                stop()
            if thread is not threading.current_thread():
                thread.join(_bound(join_s, wait_s))
            return not thread.is_alive()

        self._add(Work("thread", name, _caller(), thread.is_alive, end, thread))
        thread.start()
        return thread

    def popen(
        self,
        command: Sequence[str],
        *,
        name: str,
        stop: Callable[[], None] | None = None,
        grace_s: float = PROCESS_GRACE_S,
        **options: Any,
    ) -> subprocess.Popen[Any]:
        """`subprocess.Popen(command, **options)`, owned: `stop` (default SIGTERM) ends it."""
        process: subprocess.Popen[Any] = subprocess.Popen(command, **options)
        self._add(self._process_work(name, process, lambda: process.poll() is None, stop, grace_s))
        return process

    def process(
        self,
        process: Any,
        *,
        stop: Callable[[], None] | None = None,
        grace_s: float = PROCESS_GRACE_S,
    ) -> Any:
        """Start a `multiprocessing` process (made, not started), owned under its own name."""
        process.start()
        alive: Callable[[], bool] = process.is_alive
        self._add(self._process_work(process.name, process, alive, stop, grace_s))
        return process

    def adopt(
        self,
        kind: str,
        name: str,
        *,
        alive: Callable[[], bool],
        end: Callable[[float | None], bool],
    ) -> Work:
        """Own work started elsewhere (a library's pool): `end(wait_s)` ends it, waiting its
        own bound (`wait_s` None) or at most `wait_s`."""
        work = Work(kind, name, _caller(), alive, end, None)
        self._add(work)
        return work

    def forget(self, work: Work) -> None:
        with self._lock:
            if work in self._started:
                self._started.remove(work)

    def running(self) -> list[Work]:
        """What was started here, in this process, and still runs, oldest first."""
        with self._lock:
            self._started = [work for work in self._started if work.alive()]
            return list(self._started)

    def mark(self) -> int:
        """A mark for `end_all`: work started from now on is after it."""
        with self._lock:
            return self._count

    def end_all(self, since: int = 0, wait_s: float | None = None) -> list[Work]:
        """End what runs, started after the mark `since`, newest first, each waited for its own
        bound (or at most `wait_s`); those that did not end, each also named in one line on
        stderr."""
        left: list[Work] = []
        interrupted: KeyboardInterrupt | None = None
        for work in reversed([work for work in self.running() if work.number > since]):
            try:
                ended = work.end(wait_s)
            except KeyboardInterrupt as again:  # a second Ctrl-C: the rest still get ended
                interrupted, ended = again, False
            except Exception as error:  # one refusal must not keep the rest running
                print(f"bywire: ending {work} failed: {error}", file=sys.stderr)
                ended = False
            if not ended:
                left.append(work)
                print(f"bywire: {work} did not end", file=sys.stderr)
        if interrupted is not None:
            raise interrupted
        return left

    @contextlib.contextmanager
    def scope(self) -> Iterator[None]:
        """End, on every way out, the work started inside that still runs."""
        since = self.mark()
        try:
            yield
        finally:
            self.end_all(since)

    def _add(self, work: Work) -> None:
        self.running()  # forget the ended, so that the list stays as short as the work
        with self._lock:
            self._count += 1
            work.number = self._count
            self._started.append(work)

    @staticmethod
    def _process_work(
        name: str,
        process: _Child,
        is_alive: Callable[[], bool],
        stop: Callable[[], None] | None,
        grace_s: float,
    ) -> Work:
        def end(wait_s: float | None) -> bool:
            with contextlib.suppress(OSError):
                (stop or process.terminate)()
            if _wait(is_alive, _bound(grace_s, wait_s)):
                return True
            with contextlib.suppress(OSError):
                process.kill()
            return _wait(is_alive, KILL_WAIT_S)

        return Work("process", name, _caller(3), is_alive, end, process)


def _bound(own_s: float, cap_s: float | None) -> float:
    return own_s if cap_s is None else min(own_s, cap_s)


def _wait(alive: Callable[[], bool], timeout_s: float) -> bool:
    """Whether `alive()` turned False within `timeout_s` (polled: both kinds of child fit)."""
    deadline = time.monotonic() + timeout_s
    while alive():
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.005)
    return True


def _caller(depth: int = 2) -> str:
    """file:line of the code that called the owner's starter, inside the package if it can."""
    frame = sys._getframe(depth)  # the cheapest way to the caller's line
    path = frame.f_code.co_filename
    marker = f"{os.sep}bywire{os.sep}"
    if marker in path:
        path = "bywire" + os.sep + path.rsplit(marker, 1)[1]
    return f"{path}:{frame.f_lineno}"


OWNER = Owner()
"""The process' one owner."""

if hasattr(os, "register_at_fork"):  # not on every platform
    os.register_at_fork(after_in_child=OWNER.forget_all)
