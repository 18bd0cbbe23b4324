"""The benchmark's figures: one row per figure with its §8 target, shared by the table and JSON."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from bywire.bench.phases import PhaseResult
from bywire.bench.realtime_session import RealtimeResult
from bywire.bench.secoc import SecocCost
from bywire.bench.stats import LatencySummary, tail_note
from bywire.bench.virtual import SpeedupResult, VerifyRateResult

LATENCY_P99_LIMIT_MS = 1.0
JITTER_P99_LIMIT_MS = 1.0
CPU_LIMIT_PERCENT = 10.0
RSS_LIMIT_MB = 80.0
SPEEDUP_LIMIT = 100.0
VERIFY_RATE_LIMIT = 1000.0  # ten-second campaigns per minute with both cores (issue 12)
SECOC_COST_LIMIT_MS = 0.05  # SecOC verification's latency cost at p99 (issue 15)
BYTES_PER_MB = 1_000_000  # decimal megabytes: the stricter reading of "80 MB"


@dataclass(frozen=True, slots=True)
class Figure:
    """One measured figure in display units; ``limit`` is its target (None: for information)."""

    key: str
    section: str
    label: str
    value: float | None
    unit: str
    limit: float | None = None
    at_most: bool = True
    note: str = ""

    @property
    def met(self) -> bool | None:
        """True or False against the target; None without one. No measurement misses it."""
        if self.limit is None:
            return None
        if self.value is None:
            return False
        return self.value <= self.limit if self.at_most else self.value >= self.limit

    @property
    def target(self) -> str:
        if self.limit is None:
            return ""
        if self.limit == 0 and self.at_most:
            return "0"
        unit = self.unit if self.unit in ("", "x") else f" {self.unit}"
        return f"{'≤' if self.at_most else '≥'} {self.limit:g}{unit}"

    def as_json(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "section": self.section,
            "label": self.label,
            "value": self.value,
            "unit": self.unit,
            "target": self.target or None,
            "limit": self.limit,
            "met": self.met,
            "note": self.note,
        }


@dataclass(frozen=True, slots=True)
class BenchResult:
    """Everything one `bywire bench` run measured, and where."""

    realtime: RealtimeResult
    speedup: SpeedupResult
    verify_rate: VerifyRateResult | None
    machine: dict[str, object]
    settings: dict[str, object]
    secoc: SecocCost | None = None


def _ms(seconds: float | None) -> float | None:
    return None if seconds is None else seconds * 1000.0


def latency_figures(
    phase: PhaseResult, path: str, label: str, summary: LatencySummary
) -> list[Figure]:
    """p50, p99, p99.9 and max of one command path in one phase, and how many samples."""
    key, section = f"{phase.name}_{path}_latency", phase.name
    note = f"n={summary.samples}, {summary.unpaired} unpaired"
    return [
        Figure(f"{key}_p50_ms", section, f"{label} p50", _ms(summary.p50_s), "ms", note=note),
        Figure(
            f"{key}_p99_ms", section, f"{label} p99", _ms(summary.p99_s), "ms", LATENCY_P99_LIMIT_MS
        ),
        Figure(
            f"{key}_p999_ms",
            section,
            f"{label} p99.9",
            _ms(summary.p999_s),
            "ms",
            note=tail_note(summary.samples),
        ),
        Figure(f"{key}_max_ms", section, f"{label} max", _ms(summary.max_s), "ms"),
        Figure(f"{key}_samples", section, f"{label} samples", float(summary.samples), ""),
    ]


def task_figures(phase: PhaseResult) -> list[Figure]:
    """The 100 Hz tasks' worst p99, p99.9 and max jitter and their overruns in one phase."""
    tasks = phase.control_tasks
    worst_s = max((task.jitter_p99_s for task in tasks), default=None)
    budget = sum(task.budget_exceeded for task in tasks)
    fewest_runs = min((task.runs for task in tasks), default=0)
    return [
        Figure(
            f"{phase.name}_jitter_p99_ms",
            phase.name,
            "100 Hz jitter p99",
            _ms(worst_s),
            "ms",
            JITTER_P99_LIMIT_MS,
            note=f"worst of {len(tasks)}, 10 µs bins",
        ),
        Figure(
            f"{phase.name}_jitter_p999_ms",
            phase.name,
            "100 Hz jitter p99.9",
            _ms(max((task.jitter_p999_s for task in tasks), default=None)),
            "ms",
            note=f"worst of {len(tasks)}, {tail_note(fewest_runs)} each",
        ),
        Figure(
            f"{phase.name}_jitter_max_ms",
            phase.name,
            "100 Hz jitter max",
            _ms(max((task.jitter_max_s for task in tasks), default=None)),
            "ms",
        ),
        Figure(
            f"{phase.name}_overruns",
            phase.name,
            "100 Hz overruns",
            float(sum(task.overruns for task in tasks)),
            "",
            0.0,
            note=f"{budget}/{sum(task.runs for task in tasks)} runs over budget",
        ),
    ]


def phase_figures(phase: PhaseResult) -> list[Figure]:
    """Every figure of one phase; CPU is a target at nominal load only."""
    rows = latency_figures(phase, "can", "CAN command → DAC", phase.can_latency)
    rows += latency_figures(phase, "ibus", "IBUS frame → DAC", phase.ibus_latency)
    rows += task_figures(phase)
    nominal = phase.flood_load is None
    rows.append(
        Figure(
            f"{phase.name}_cpu_percent",
            phase.name,
            "CPU, controller",
            phase.controller_cpu_share * 100.0,
            "%",
            CPU_LIMIT_PERCENT if nominal else None,
            note=f"tasks alone {phase.tasks_share * 100:.1f} %",
        )
    )
    rows.append(
        Figure(
            f"{phase.name}_process_cpu_percent",
            phase.name,
            "CPU, whole process",
            phase.cpu_share * 100.0,
            "%",
            note=f"simulator {phase.sim_cpu_share * 100:.1f} %",
        )
    )
    rows.append(
        Figure(
            f"{phase.name}_bus_load_percent",
            phase.name,
            "CAN bus load",
            phase.bus_load * 100.0,
            "%",
            note=f"{phase.stops} falls to STOP",
        )
    )
    rows.append(
        Figure(
            f"{phase.name}_steal_percent",
            phase.name,
            "Machine: CPU stolen by the host",
            phase.steal_share * 100.0,
            "%",
            note=f"some task waited for a CPU {phase.cpu_pressure_share * 100:.0f} % of the time",
        )
    )
    return rows


def all_figures(result: BenchResult) -> list[Figure]:
    """The table's rows, in order: each phase, then memory and the virtual-time speed-up."""
    rows = [row for phase in result.realtime.phases for row in phase_figures(phase)]
    speedup = result.speedup
    timing = f"{speedup.scenario} {speedup.simulated_s:g} s in {speedup.wall_s:.2f} s"
    if speedup.simulated_s < speedup.scenario_duration_s:
        checks = "cut short"
    else:
        checks = f"{speedup.expectations_passed}/{speedup.expectations_total} ok"
    rows.append(
        Figure(
            "peak_rss_mb",
            "process",
            "Peak resident memory",
            result.realtime.peak_rss_bytes / BYTES_PER_MB,
            "MB",
            RSS_LIMIT_MB,
            note="1 MB = 10^6 bytes",
        )
    )
    rows.append(
        Figure(
            "virtual_speedup",
            "process",
            "Virtual-time speed-up",
            speedup.speedup,
            "x",
            SPEEDUP_LIMIT,
            at_most=False,
            note=f"{timing}, {checks}",
        )
    )
    rate = result.verify_rate
    if rate is not None:
        rows.append(
            Figure(
                "verify_campaigns_per_min",
                "process",
                f"bywire verify, {rate.campaign_s:g} s campaigns per minute",
                rate.per_minute,
                "/min",
                VERIFY_RATE_LIMIT,
                at_most=False,
                note=f"{rate.campaigns} campaigns on {rate.jobs} processes in {rate.wall_s:.1f} s"
                f" ({rate.simulated_s / rate.wall_s:.0f}x real time)",
            )
        )
    if result.secoc is not None:
        rows += secoc_figures(result.secoc)
    return rows


def secoc_figures(cost: SecocCost) -> list[Figure]:
    """What verifying authenticated commands costs per command, and the second frame's time."""
    plain, secure = cost.plain, cost.authenticated
    return [
        Figure(
            "secoc_cost_p99_ms",
            "secoc",
            "SecOC verification cost p99",
            _ms(cost.p99_cost_s),
            "ms",
            SECOC_COST_LIMIT_MS,
            note="CPU time of the reader per command, authenticated minus plain",
        ),
        Figure("secoc_plain_p50_ms", "secoc", "CAN reader, plain p50", _ms(plain.p50_s), "ms"),
        Figure("secoc_plain_p99_ms", "secoc", "CAN reader, plain p99", _ms(plain.p99_s), "ms"),
        Figure(
            "secoc_auth_p50_ms", "secoc", "CAN reader, authenticated p50", _ms(secure.p50_s), "ms"
        ),
        Figure(
            "secoc_auth_p99_ms",
            "secoc",
            "CAN reader, authenticated p99",
            _ms(secure.p99_s),
            "ms",
            note=f"CPU time, n={secure.samples} each, interleaved",
        ),
        Figure(
            "secoc_wall_cost_p99_ms",
            "secoc",
            "SecOC cost p99, wall clock",
            _ms(cost.p99_wall_cost_s),
            "ms",
            note="preemption included: the machine's share, not the reader's",
        ),
        Figure(
            "secoc_wire_ms",
            "secoc",
            "Cryptographic PDU on the wire",
            _ms(cost.wire_s),
            "ms",
            note="8 bytes at 500 kbit/s, worst-case stuffing: the wait for the second half",
        ),
    ]


def as_json(result: BenchResult) -> dict[str, Any]:
    """The same figures as the table, plus the details behind them (SI units)."""
    rows = all_figures(result)
    speedup = result.speedup
    return {
        "figures": [row.as_json() for row in rows],
        "targets_missed": [row.key for row in rows if row.met is False],
        "phases": [
            {**asdict(phase), "tasks_share": phase.tasks_share} for phase in result.realtime.phases
        ],
        "peak_rss_bytes": result.realtime.peak_rss_bytes,
        "virtual_time": {**asdict(speedup), "speedup": speedup.speedup},
        "verify_rate": None
        if result.verify_rate is None
        else {**asdict(result.verify_rate), "per_minute": result.verify_rate.per_minute},
        "secoc": None if result.secoc is None else asdict(result.secoc),
        "machine": result.machine,
        "settings": result.settings,
        "tail": None
        if result.realtime.tail is None
        else [asdict(phase) for phase in result.realtime.tail],
    }
