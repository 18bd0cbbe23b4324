"""Threads that serve looking, logging or persistence leave the control loop's real-time priority.

`bywire run` may put the process under SCHED_FIFO (`[realtime] scheduler = "fifo"`), and Linux
gives every thread (and child process) the policy of the thread that created it: the telemetry
writer's process with foxglove-sdk's server and file threads, the log writer and the freshness
writer would then compete with the control loop at its own priority, each able to
keep it off a CPU. The loop and the threads that
deliver its input (CAN, UART) and watch it (the watchdog) keep the real-time policy; every other
thread calls `leave_realtime()` first. Lowering one's own policy needs no privilege.

`outside_realtime(work)` runs `work` in a short-lived thread that has left it, so that the threads
a library starts there (foxglove-sdk's runtime) are born under the normal policy too.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TypeVar

from bywire.background import OWNER

T = TypeVar("T")

_REALTIME_POLICIES = frozenset(
    getattr(os, name) for name in ("SCHED_FIFO", "SCHED_RR") if hasattr(os, name)
)


def leave_realtime() -> None:
    """Put the calling thread back under the normal scheduler if it runs under FIFO or RR.

    Any other policy (a user's SCHED_BATCH or SCHED_IDLE) is left as it is; where the platform
    has no such calls, nothing happens.
    """
    try:
        if os.sched_getscheduler(0) in _REALTIME_POLICIES:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError):  # not Linux; or a policy this kernel will not lower
        return


def outside_realtime(work: Callable[[], T]) -> T:
    """`work()`'s result, computed in a thread that left the real-time policy first; its
    exception is raised here. Threads `work` starts inherit the normal policy."""
    outcome: list[T] = []
    failure: list[BaseException] = []

    def run() -> None:
        leave_realtime()
        try:
            outcome.append(work())
        except BaseException as error:  # handed to the caller's thread
            failure.append(error)

    thread = OWNER.thread(run, name="bywire-outside-realtime")
    thread.join()
    if failure:
        raise failure[0]
    return outcome[0]
