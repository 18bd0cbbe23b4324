"""The machine a benchmark ran on, and the process's peak resident memory."""

from __future__ import annotations

import datetime
import os
import platform
import resource
import sys
from pathlib import Path

from bywire.build import build_name

CPUINFO = Path("/proc/cpuinfo")
PROC_STAT = Path("/proc/stat")
CPU_PRESSURE = Path("/proc/pressure/cpu")
STEAL_FIELD = 8  # "cpu user nice system idle iowait irq softirq steal ..." in /proc/stat


def peak_rss_bytes() -> int:
    """The process's peak resident set size so far (Linux reports KiB, macOS bytes)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def cpu_model(cpuinfo: Path = CPUINFO) -> str:
    """The CPU's model name from /proc/cpuinfo, else what the platform module says."""
    try:
        for line in cpuinfo.read_text(encoding="utf-8", errors="replace").splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def machine_info() -> dict[str, object]:
    """What RESULTS.md records about the machine: CPUs, model, Python, bywire's build (pure or
    compiled), OS, load, date."""
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load_1m = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    return {
        "cpu_model": cpu_model(),
        "logical_cpus": os.cpu_count(),
        "usable_cpus": usable,
        "load_average_1m": load_1m,
        "python": platform.python_version(),
        "build": build_name(),
        "python_implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def steal_s(stat: Path = PROC_STAT) -> float:
    """CPU seconds the hypervisor took from this machine's CPUs since boot (all CPUs added up).

    On a virtual machine this is time the guest wanted to run and the host ran something else;
    the guest's scheduler cannot see it (0 on bare metal, or where /proc/stat is unreadable).
    """
    try:
        for line in stat.read_text(encoding="ascii").splitlines():
            fields = line.split()
            if fields and fields[0] == "cpu" and len(fields) > STEAL_FIELD:
                return int(fields[STEAL_FIELD]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError):
        pass
    return 0.0


def cpu_pressure_s(pressure: Path = CPU_PRESSURE) -> float:
    """Seconds during which at least one task waited for a CPU since boot (Linux PSI, "some");
    0 where the kernel does not report pressure."""
    try:
        for line in pressure.read_text(encoding="ascii").splitlines():
            if line.startswith("some "):
                total = dict(item.split("=") for item in line.split()[1:])["total"]
                return int(total) * 1e-6
    except (OSError, ValueError, KeyError):
        pass
    return 0.0
