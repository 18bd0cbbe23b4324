"""The leak check every test runs under (autouse, from conftest): a thread or a child process that
the test started and left running fails it, named; a leaked process is killed so that it cannot
live on (issue 42: a failing test left `bywire run --dashboard` and its writer running 39 min).

Threads: `threading.enumerate()` before and after the test, after a short bounded grace for
those already asked to stop. Processes: the test process' own children, read from the kernel
(`/proc/self/task/*/children`), and whatever bywire's owner (`bywire.background.OWNER`) started
and still runs (a child in a session of its own, or a grandchild, is there too). Libraries'
own long-lived helpers are allowed by name below, never by blanket.
"""

from __future__ import annotations

import os
import re
import signal
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from bywire.background import OWNER, Work

GRACE_S = 2.0  # how long work asked to stop may take to go before it counts as left running
POLL_S = 0.01

ALLOWED_THREADS = re.compile(
    r"^("
    r"asyncio_\d+"  # asyncio's default executor: idle workers of a closed loop go on their own
    r"|Dask-Offload_\d+"  # distributed's one module-wide executor, kept for the process's life
    r")$"
)
"""Threads a library keeps for the session, by name."""

ALLOWED_PROCESSES = re.compile(r"multiprocessing\.(resource_tracker|forkserver)")
"""Child processes (command lines) the standard library keeps for the session."""


@dataclass(frozen=True)
class Snapshot:
    threads: frozenset[threading.Thread]
    children: frozenset[int]
    owned: frozenset[int]  # id() of the owner's work


def snapshot() -> Snapshot:
    return Snapshot(
        frozenset(threading.enumerate()), frozenset(children()), frozenset(map(id, OWNER.running()))
    )


def children(pid: int | str = "self") -> set[int]:
    """The live (not zombie) descendants of a process (this one by default), as the kernel
    lists them: a grandchild counts while its parent lives (once orphaned it is init's)."""
    found: set[int] = set()
    for listing in Path(f"/proc/{pid}/task").glob("*/children"):
        try:
            found |= {int(child) for child in listing.read_text().split()}
        except OSError:  # the thread ended while we read
            continue
    live = {child for child in found if _state(child) not in ("Z", "X", None)}
    return live.union(*(children(child) for child in live))


def left_running(before: Snapshot) -> list[str]:
    """What the test left running, each named; processes among them are killed."""
    deadline = time.monotonic() + GRACE_S
    while True:
        threads, pids, owned = _new(before)
        if not (threads or pids or owned) or time.monotonic() >= deadline:
            break
        time.sleep(POLL_S)
    named = [str(work) for work in owned]
    named += [f"thread {thread.name!r}" for thread in threads if not _owned(thread, owned)]
    owned_pids = {getattr(work.handle, "pid", None) for work in owned}
    named += [f"process {pid} ({_command(pid)})" for pid in sorted(pids - owned_pids)]
    for work in reversed(owned):
        work.end(0.0)
        OWNER.forget(work)
    for pid in sorted(pids, reverse=True):  # the newest first: grandchildren before parents
        _kill(pid)
    return named


def _new(before: Snapshot) -> tuple[list[threading.Thread], set[int], list[Work]]:
    threads = [
        thread
        for thread in threading.enumerate()
        if thread not in before.threads
        and not ALLOWED_THREADS.match(thread.name)
        and not isinstance(thread, threading._DummyThread)  # a foreign (native) thread's face
    ]
    pids = {
        pid for pid in children() - before.children if not ALLOWED_PROCESSES.search(_command(pid))
    }
    owned = [work for work in OWNER.running() if id(work) not in before.owned]
    return threads, pids, owned


def _owned(thread: threading.Thread, owned: list[Work]) -> bool:
    return any(work.handle is thread for work in owned)


def _state(pid: int) -> str | None:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _command(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return "gone"
    return raw.replace(b"\0", b" ").decode(errors="replace").strip()[:160]


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        return


@pytest.fixture(autouse=True)
def no_leaks() -> Iterator[None]:
    """Fail the test that leaves a thread or a process of ours running (and kill the process)."""
    before = snapshot()
    yield
    found = left_running(before)
    if found:
        pytest.fail("left running after the test: " + "; ".join(found), pytrace=False)
