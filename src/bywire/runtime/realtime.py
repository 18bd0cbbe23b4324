"""Process settings for the control loop: scheduler, locked memory, CPU affinity, the collector.

Two steps, in this order:

1. `apply_process` before the hardware is opened: ``SCHED_FIFO``, ``mlockall`` and the CPU
   affinity are set on the calling thread, and every thread started afterwards (the CAN and UART
   readers, the watchdog) inherits them.
2. `apply_collector` once the runtime is built: ``gc.freeze()`` moves every object made during
   start-up out of the collector's sight, and ``gc_mode = "idle"`` takes the collector off
   automatic and runs it between passes instead, when the next deadline is far enough away.

Each setting is applied only when the configuration asks for it and only if the kernel permits
it. A refusal never raises: it is a `Refusal` naming the reason and the fix (a capability, or a
line of the systemd unit), and the loop runs without that setting.
"""

from __future__ import annotations

import ctypes
import errno
import gc
import os
import resource
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from bywire.config import RealtimeSection

MCL_CURRENT, MCL_FUTURE = 1, 2  # <sys/mman.h> on Linux
CAP_IPC_LOCK = 14  # <linux/capability.h>
PROC_STATUS = Path("/proc/self/status")
LOCKED_THREAD_STACK_BYTES = 1 << 20
"""With memory locked, each thread's whole stack is resident: 1 MiB instead of glibc's 8 MiB
(bywire's threads run shallow Python: the watchdog, the CAN and UART readers)."""
IDLE_MARGIN_S = 0.002
"""In ``idle`` mode, collect only after a pass that leaves at least this long to the next deadline
(a young-generation collection takes ~0.1–0.2 ms, an older one ~1 ms on a desktop CPU)."""
FORCE_FACTOR = 20
"""…or, whatever the time, once this many times the young generation's threshold is pending, so
that a loop that is never idle still frees its cycles."""
SCHED_FIX = (
    "grant CAP_SYS_NICE (sudo setcap cap_sys_nice,cap_ipc_lock+ep $(readlink -f {python})) or set"
    " LimitRTPRIO={priority} in the systemd unit (deploy/bywire.service)"
)
MEMLOCK_FIX = (
    "grant CAP_IPC_LOCK (sudo setcap cap_sys_nice,cap_ipc_lock+ep $(readlink -f {python})) or set"
    " LimitMEMLOCK=infinity in the systemd unit (deploy/bywire.service)"
)


@dataclass(frozen=True, slots=True)
class Refusal:
    """A configured setting the kernel (or a limit) did not allow, why, and how to allow it."""

    setting: str
    reason: str
    fix: str

    def __str__(self) -> str:
        return (
            f"{self.setting} refused: {self.reason}; {self.fix}"
            if self.fix
            else (f"{self.setting} refused: {self.reason}")
        )


@dataclass(slots=True)
class RealtimeReport:
    """What was applied and what was refused, for the start-up line and the benchmark."""

    applied: list[str] = field(default_factory=list)
    refused: list[Refusal] = field(default_factory=list)

    def extend(self, other: RealtimeReport) -> None:
        self.applied += other.applied
        self.refused += other.refused

    def line(self) -> str:
        """One line: 'real-time: applied A, B; refused C (reason)' (or 'none' for either)."""
        applied = ", ".join(self.applied) or "none"
        refused = ", ".join(f"{r.setting} ({r.reason})" for r in self.refused) or "none"
        return f"real-time: applied {applied}; refused {refused}"

    def as_json(self) -> dict[str, object]:
        return {
            "applied": list(self.applied),
            "refused": [
                {"setting": r.setting, "reason": r.reason, "fix": r.fix} for r in self.refused
            ],
        }


# --- step 1: the process ------------------------------------------------------------------------


def apply_process(settings: RealtimeSection, python: str = "python3") -> RealtimeReport:
    """Scheduler, memory lock and CPU affinity, each if configured and permitted.

    ``python`` is the interpreter's path, for the ``setcap`` line of a refusal.
    """
    report = RealtimeReport()
    if settings.cpu_set is not None:
        _affinity(settings.cpu_set, settings.cpus, report)
    if settings.lock_memory:
        _lock_memory(report, python)
    if settings.scheduler == "fifo":
        _fifo(settings.priority, report, python)
    return report


def _fifo(priority: int, report: RealtimeReport, python: str) -> None:
    setting = f"SCHED_FIFO {priority}"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as error:
        fix = SCHED_FIX.format(python=python, priority=priority)
        if error.errno != errno.EPERM:
            fix = ""
        report.refused.append(Refusal(setting, _reason(error), fix))
        return
    report.applied.append(setting)


def _lock_memory(report: RealtimeReport, python: str) -> None:
    setting = "mlockall"
    fix = MEMLOCK_FIX.format(python=python)
    soft, _hard = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    if soft != resource.RLIM_INFINITY and not has_capability(CAP_IPC_LOCK):
        # MCL_FUTURE under a finite limit would make every allocation past it fail later, in
        # the loop: refuse now instead.
        reason = f"RLIMIT_MEMLOCK is {soft} bytes and the process lacks CAP_IPC_LOCK"
        report.refused.append(Refusal(setting, reason, fix))
        return
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        number = ctypes.get_errno()
        report.refused.append(Refusal(setting, _reason(OSError(number, os.strerror(number))), fix))
        return
    threading.stack_size(LOCKED_THREAD_STACK_BYTES)
    report.applied.append(setting)


def _affinity(cpus: frozenset[int], text: str, report: RealtimeReport) -> None:
    setting = f"CPUs {text}"
    available = os.sched_getaffinity(0)
    if not cpus <= available:
        missing = ",".join(map(str, sorted(cpus - available)))
        reason = f"CPU {missing} not available (this process may use {_cpu_text(available)})"
        report.refused.append(Refusal(setting, reason, "set realtime.cpus to CPUs it may use"))
        return
    try:
        os.sched_setaffinity(0, cpus)
    except OSError as error:
        report.refused.append(Refusal(setting, _reason(error), ""))
        return
    report.applied.append(setting)


def has_capability(number: int, status: Path = PROC_STATUS) -> bool:
    """True if the process's effective capability set holds capability ``number``."""
    try:
        for line in status.read_text(encoding="ascii").splitlines():
            key, _, value = line.partition(":")
            if key == "CapEff":
                return bool(int(value.strip(), 16) >> number & 1)
    except (OSError, ValueError):
        pass
    return False


def _reason(error: OSError) -> str:
    name = errno.errorcode.get(error.errno or 0, "error")
    return f"{name}, {error.strerror or error}"


def _cpu_text(cpus: set[int] | frozenset[int]) -> str:
    return ",".join(map(str, sorted(cpus)))


# --- step 2: the collector ----------------------------------------------------------------------


class LoopClock(Protocol):
    def now(self) -> float: ...


class LoopTask(Protocol):
    @property
    def next_deadline_s(self) -> float: ...


class Loop(Protocol):
    """What the collector needs of the runtime: its clock, its tasks, its per-pass observers."""

    @property
    def clock(self) -> LoopClock: ...

    @property
    def tasks(self) -> Sequence[LoopTask]: ...

    @property
    def on_cycle(self) -> list[Callable[[float], None]]: ...


class IdleCollector:
    """Collects between passes, when the next deadline is at least ``margin_s`` away.

    Registered as one of the runtime's per-pass observers while automatic collection is off. It
    picks the generation as CPython would (the oldest whose count passed its threshold).
    """

    def __init__(self, loop: Loop, margin_s: float = IDLE_MARGIN_S) -> None:
        self.loop = loop
        self.margin_s = margin_s
        self.thresholds = gc.get_threshold()
        self.quiet = 0
        self.forced = 0

    def __call__(self, _now: float) -> None:
        young, middle, old = gc.get_count()
        threshold0, threshold1, threshold2 = self.thresholds
        if young < threshold0:
            return
        next_s = min(task.next_deadline_s for task in self.loop.tasks)
        if next_s - self.loop.clock.now() < self.margin_s:
            if young < FORCE_FACTOR * threshold0:
                return
            self.forced += 1
        else:
            self.quiet += 1
        generation = 0
        if middle >= threshold1:
            generation = 2 if old >= threshold2 else 1
        gc.collect(generation)


@dataclass(slots=True)
class Collector:
    """The collector's settings as applied; `release` gives collection back to Python."""

    report: RealtimeReport
    idle: IdleCollector | None = None
    loop: Loop | None = None

    def release(self) -> None:
        if self.idle is not None and self.loop is not None:
            if self.idle in self.loop.on_cycle:
                self.loop.on_cycle.remove(self.idle)
            gc.enable()
            self.idle = None


def apply_collector(settings: RealtimeSection, loop: Loop) -> Collector:
    """gc.freeze() and the idle mode, as configured; call once start-up has built everything."""
    report = RealtimeReport()
    collector = Collector(report)
    if settings.gc_freeze:
        gc.freeze()
        report.applied.append(f"gc.freeze ({gc.get_freeze_count()} objects)")
    if settings.gc_mode == "idle":
        gc.disable()
        collector.idle, collector.loop = IdleCollector(loop), loop
        loop.on_cycle.append(collector.idle)
        report.applied.append(f"gc between passes (>= {IDLE_MARGIN_S * 1e3:g} ms idle)")
    return collector
