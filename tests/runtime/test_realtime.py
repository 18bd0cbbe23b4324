"""`bywire.runtime.realtime`: each setting applied when permitted, refused when not, for real.

The process-wide settings (scheduler, memory lock, affinity) are tried in a child process, so that
this one keeps its own; an unprivileged child is made by dropping to user nobody with setpriv when
the tests run as root, and by lowering RLIMIT_RTPRIO and RLIMIT_MEMLOCK otherwise. Nothing here
fakes a system call: the kernel answers.
"""

from __future__ import annotations

import gc
import json
import os
import resource
import shutil
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.config import RealtimeSection, default_sim_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.runtime.loop import Runtime
from bywire.runtime.realtime import (
    CAP_IPC_LOCK,
    RealtimeReport,
    Refusal,
    apply_collector,
    has_capability,
)
from bywire.runtime.settings import RuntimeConfig

SRC = Path(__file__).resolve().parents[2] / "src"
NOBODY = 65534
CHILD = """
import json, os, resource, threading
from bywire.config import RealtimeSection

if {lower_limits!r}:
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))
from bywire.runtime.realtime import apply_process

report = apply_process(RealtimeSection(**json.loads({settings!r})), python="/usr/bin/python3")
seen = {{}}
def look():
    seen["thread_policy"] = os.sched_getscheduler(0)
thread = threading.Thread(target=look)
thread.start()
thread.join()
status = dict(
    line.split(":", 1) for line in open("/proc/self/status") if ":" in line
)
print(json.dumps({{
    "applied": report.applied,
    "refused": [[r.setting, r.reason, r.fix] for r in report.refused],
    "policy": os.sched_getscheduler(0),
    "thread_policy": seen["thread_policy"],
    "priority": os.sched_getparam(0).sched_priority,
    "cpus": sorted(os.sched_getaffinity(0)),
    "locked_kb": int(status["VmLck"].split()[0]),
    "stack_bytes": threading.stack_size(),
}}))
"""


def _child(settings: dict[str, object], *, privileged: bool) -> dict[str, object]:
    """Apply ``settings`` in a fresh interpreter and report what the kernel then says."""
    code = textwrap.dedent(CHILD.format(settings=json.dumps(settings), lower_limits=not privileged))
    command = [sys.executable, "-c", code]
    if not privileged and os.geteuid() == 0:
        command = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups", *command]

    done = subprocess.run(
        command,
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": str(SRC)},
        cwd="/",
        timeout=60,
    )
    result: dict[str, object] = json.loads(done.stdout)
    return result


def _only_refusal(seen: dict[str, object]) -> tuple[str, str, str]:
    """The child's one refusal, as (setting, reason, fix); fails if there is not exactly one."""
    refused = seen["refused"]
    assert isinstance(refused, list)
    (entry,) = refused
    setting, reason, fix = entry
    assert isinstance(setting, str)
    assert isinstance(reason, str)
    assert isinstance(fix, str)
    return setting, reason, fix


def _may_use_fifo() -> bool:
    soft, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
    return os.geteuid() == 0 or soft >= RealtimeSection().priority


def _may_lock() -> bool:
    soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    return soft == resource.RLIM_INFINITY or has_capability(CAP_IPC_LOCK)


unprivileged = pytest.mark.skipif(
    os.geteuid() == 0 and shutil.which("setpriv") is None, reason="root, and no setpriv to drop it"
)


# --- refused: each names the reason and the fix, nothing changes, nothing raises ----------------


@unprivileged
def test_sched_fifo_refused_by_the_kernel_names_cap_sys_nice_and_limitrtprio() -> None:
    seen = _child({"scheduler": "fifo", "priority": 40}, privileged=False)
    assert seen["applied"] == []
    setting, reason, fix = _only_refusal(seen)
    assert setting == "SCHED_FIFO 40"
    assert reason.startswith("EPERM")
    assert "cap_sys_nice" in fix
    assert "LimitRTPRIO=40" in fix
    assert seen["policy"] == os.SCHED_OTHER


@unprivileged
def test_mlockall_under_a_finite_limit_is_refused_naming_limitmemlock() -> None:
    seen = _child({"lock_memory": True}, privileged=False)
    setting, reason, fix = _only_refusal(seen)
    assert setting == "mlockall"
    assert "RLIMIT_MEMLOCK is 65536 bytes" in reason
    assert "LimitMEMLOCK=infinity" in fix
    assert "cap_ipc_lock" in fix
    assert seen["locked_kb"] == 0
    assert seen["stack_bytes"] == 0  # the platform's default


def test_cpus_the_process_may_not_use_are_refused_naming_those_it_may() -> None:
    available = sorted(os.sched_getaffinity(0))
    seen = _child({"cpus": "1023"}, privileged=True)
    setting, reason, _fix = _only_refusal(seen)
    assert setting == "CPUs 1023"
    assert f"may use {','.join(map(str, available))}" in reason
    assert seen["cpus"] == available


def test_nothing_configured_applies_nothing() -> None:
    seen = _child({}, privileged=True)
    assert seen["applied"] == seen["refused"] == []
    assert seen["policy"] == os.SCHED_OTHER


# --- applied: the kernel reports the new state, and threads started later inherit it -----------


def test_affinity_is_applied_and_inherited() -> None:
    cpu = max(os.sched_getaffinity(0))
    seen = _child({"cpus": str(cpu)}, privileged=True)
    assert seen["applied"] == [f"CPUs {cpu}"]
    assert seen["cpus"] == [cpu]


@pytest.mark.skipif(not _may_use_fifo(), reason="this user may not use SCHED_FIFO")
def test_sched_fifo_is_applied_and_threads_started_afterwards_inherit_it() -> None:
    seen = _child({"scheduler": "fifo", "priority": 12}, privileged=True)
    assert seen["applied"] == ["SCHED_FIFO 12"]
    assert (seen["policy"], seen["priority"]) == (os.SCHED_FIFO, 12)
    assert seen["thread_policy"] == os.SCHED_FIFO


@pytest.mark.skipif(not _may_lock(), reason="this user may not lock all its memory")
def test_mlockall_locks_the_process_memory() -> None:
    seen = _child({"lock_memory": True}, privileged=True)
    assert seen["applied"] == ["mlockall"]
    assert isinstance(seen["locked_kb"], int)
    assert seen["locked_kb"] > 1000
    assert seen["stack_bytes"] == 1 << 20  # each new thread locks 1 MiB of stack, not 8


def test_the_start_up_line_says_what_was_applied_and_what_was_refused() -> None:
    report = RealtimeReport(["CPUs 1"], [Refusal("SCHED_FIFO 40", "EPERM, not permitted", "fix")])
    assert report.line() == (
        "real-time: applied CPUs 1; refused SCHED_FIFO 40 (EPERM, not permitted)"
    )
    assert RealtimeReport().line() == "real-time: applied none; refused none"
    assert str(report.refused[0]) == "SCHED_FIFO 40 refused: EPERM, not permitted; fix"


def test_capabilities_are_read_from_the_effective_set(tmp_path: Path) -> None:
    status = tmp_path / "status"
    status.write_text("Name:\tx\nCapEff:\t0000000000004000\n", encoding="ascii")
    assert has_capability(CAP_IPC_LOCK, status)
    assert not has_capability(CAP_IPC_LOCK - 1, status)
    assert not has_capability(CAP_IPC_LOCK, tmp_path / "missing")


# --- the collector ------------------------------------------------------------------------------


@pytest.fixture
def collector_restored() -> Iterator[None]:
    thresholds = gc.get_threshold()
    yield
    gc.enable()
    gc.unfreeze()
    gc.set_threshold(*thresholds)


@pytest.mark.usefixtures("collector_restored")
def test_gc_freeze_moves_the_start_up_objects_out_of_the_collectors_sight() -> None:
    gc.unfreeze()
    clock = VirtualClock()
    world = SimWorld.from_robot(clock, default_sim_config())
    runtime = Runtime(world.hardware, RuntimeConfig.from_robot(default_sim_config()))
    collector = apply_collector(RealtimeSection(gc_freeze=True), runtime)
    assert gc.get_freeze_count() > 10_000
    assert collector.report.applied[0].startswith("gc.freeze (")
    assert gc.isenabled()  # automatic mode: Python still collects on its own


@pytest.mark.usefixtures("collector_restored")
def test_in_idle_mode_every_collection_happens_between_passes() -> None:
    clock = VirtualClock()
    robot = default_sim_config()
    world = SimWorld.from_robot(clock, robot)
    runtime = Runtime(world.hardware, RuntimeConfig.from_robot(robot), watchdog_thread=False)
    gc.set_threshold(100, 10, 10)  # small, so that a short run collects often
    collector = apply_collector(RealtimeSection(gc_mode="idle"), runtime)
    collections: list[int] = []
    gc.callbacks.append(cb := lambda phase, info: collections.append(info["generation"]))
    try:
        world.rc.start(0.0)
        world.hlc.start(0.0)
        world.vehicle.start(0.0)
        assert not gc.isenabled()
        runtime.run(until_s=5.0)
    finally:
        gc.callbacks.remove(cb)
    idle = collector.idle
    assert idle is not None
    starts = len(collections) // 2  # a start and a stop callback per collection
    assert idle.quiet > 10
    assert starts == idle.quiet + idle.forced  # none came from Python's automatic collector
    assert {0, 1} <= set(collections)
    collector.release()
    assert gc.isenabled()
    assert idle not in runtime.on_cycle
