"""Looking, logging and persisting threads leave the loop's real-time policy; the loop keeps it.

Judged on what the kernel says of each thread (`/proc/<pid>/task/<tid>/stat`, the policy field),
in a real child process, so that no thread an earlier test started can make the check pass.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

from bywire.priority import leave_realtime, outside_realtime

FIFO_PRIORITY = 10


def _fifo_permitted() -> bool:
    """Whether this machine lets a thread take SCHED_FIFO (root, CAP_SYS_NICE or RLIMIT_RTPRIO);
    tried on a thread of its own, so the test process keeps its policy."""
    permitted: list[bool] = []

    def attempt() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
        except OSError:
            permitted.append(False)
        else:
            permitted.append(True)

    thread = threading.Thread(target=attempt)
    thread.start()
    thread.join()
    return permitted[0]


needs_fifo = pytest.mark.skipif(
    not hasattr(os, "SCHED_FIFO") or not _fifo_permitted(),
    reason="this machine refuses SCHED_FIFO to the tests: no real-time policy to leave",
)


def _on_a_thread(work: Callable[[], None]) -> None:
    failures: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as error:
            failures.append(error)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    if failures:
        raise failures[0]


@needs_fifo
def test_a_fifo_thread_leaves_it_and_a_batch_thread_keeps_its_policy() -> None:
    def fifo() -> None:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
        leave_realtime()
        assert os.sched_getscheduler(0) == os.SCHED_OTHER

    def batch() -> None:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
        leave_realtime()
        assert os.sched_getscheduler(0) == os.SCHED_BATCH

    _on_a_thread(fifo)
    _on_a_thread(batch)


@needs_fifo
def test_outside_realtime_runs_the_work_under_the_normal_policy_from_a_fifo_thread() -> None:
    seen: list[int] = []

    def fifo() -> None:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
        seen.append(outside_realtime(lambda: os.sched_getscheduler(0)))
        assert os.sched_getscheduler(0) == os.SCHED_FIFO  # the caller keeps its own

    _on_a_thread(fifo)
    assert seen == [os.SCHED_OTHER]


def test_outside_realtime_hands_back_the_result_and_the_exception() -> None:
    assert outside_realtime(lambda: 42) == 42

    def fail() -> None:
        raise ValueError("the sink could not open")

    with pytest.raises(ValueError, match="could not open"):
        outside_realtime(fail)


CHILD = """
import json, os, sys, threading
from pathlib import Path
from bywire.hal.simulated.clock import VirtualClock
from bywire.loopback import Endpoint
from bywire.telemetry.feed import FeedOptions, open_sinks

os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))  # as `bywire run` with fifo
options = FeedOptions(mcap_path=Path(sys.argv[1]), foxglove=Endpoint("127.0.0.1", 0))

def policies(pid):
    seen = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        stat = Path(f"/proc/{pid}/task/{tid}/stat").read_text()
        policy = int(stat.rsplit(")", 1)[1].split()[38])
        name = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
        seen[f"{name} {tid}"] = policy
    return seen

with open_sinks(options, VirtualClock(), virtual_time=False) as sinks:
    main = f"{Path('/proc/self/comm').read_text().strip()} {os.getpid()}"
    print(json.dumps({
        "main": main, "policies": policies("self"), "writer": policies(sinks.writer.pid)
    }))
"""


@needs_fifo
def test_the_feeds_threads_are_born_under_the_normal_policy_in_a_fifo_process(
    tmp_path: Path,
) -> None:
    """The telemetry writer's process with foxglove-sdk's server and file threads (and any
    thread the feed leaves in the controller's process), started by a process whose main thread
    runs under SCHED_FIFO (as `bywire run` with `scheduler = "fifo"`). The writer's threads run
    under SCHED_BATCH, which never preempts the loop when the pipe wakes them."""
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(tmp_path / "feed.mcap")],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    report = json.loads(done.stdout)
    policies: dict[str, int] = report["policies"]
    assert policies.pop(report["main"]) == os.SCHED_FIFO  # the loop's thread keeps it
    writer: dict[str, int] = report["writer"]
    assert len(writer) >= 3, f"expected the writer's and the SDK's threads, saw {writer}"
    fifo = [name for name, policy in {**policies, **writer}.items() if policy == os.SCHED_FIFO]
    assert fifo == [], f"threads serving the feed at the loop's priority: {fifo}"
    assert set(writer.values()) == {os.SCHED_BATCH}, writer
