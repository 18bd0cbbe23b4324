"""One benchmark phase and what it yields: latencies, the 100 Hz tasks' figures, CPU and bus load.

A phase is a stretch of real time with a fixed load (nominal, or the bus flooded by other nodes).
Its first half drives the robot over CAN, its second half by RC; latencies of each path are taken
from its half only, after a settling time that lets the mode switch take effect.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from bywire.bench.clocks import MeteredClock
from bywire.bench.latency import DacWrite, Pairing, SentCommand, pair_writes
from bywire.bench.machine import cpu_pressure_s, steal_s
from bywire.bench.stats import LatencySummary, summarise
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.model import ControlMode
from bywire.runtime.schedule import PeriodicTask, TaskStats

CONTROL_RATE_HZ = 100.0  # the rate of the tasks §8's jitter figure is about


@dataclass(frozen=True, slots=True)
class Marks:
    """Process and simulator CPU time, wall time, bits on the bus, and the machine's stolen CPU
    time and CPU pressure at one instant."""

    cpu_s: float
    sim_cpu_s: float
    wall_s: float
    bus_bits: int
    steal_s: float = 0.0
    pressure_s: float = 0.0

    @classmethod
    def take(cls, clock: MeteredClock, bus: SimCanBus) -> Marks:
        return cls(
            time.process_time(),
            clock.waiting_cpu_s,
            time.perf_counter(),
            bus.bits_sent(),
            steal_s(),
            cpu_pressure_s(),
        )


@dataclass(slots=True)
class PhaseWindow:
    """Where a phase lies on the clock, and the counters read at its start and end."""

    name: str
    start_s: float
    end_s: float
    flood_load: float | None
    settle_s: float
    started: Marks | None = None
    ended: Marks | None = None
    task_stats: list[tuple[PeriodicTask, TaskStats]] = field(default_factory=list)

    @property
    def half_s(self) -> float:
        """Where the CAN half ends and the RC half begins."""
        return (self.start_s + self.end_s) / 2

    def can_span(self) -> tuple[float, float]:
        return self.start_s + self.settle_s, self.half_s

    def rc_span(self) -> tuple[float, float]:
        return self.half_s + self.settle_s, self.end_s


@dataclass(frozen=True, slots=True)
class TaskFigures:
    """One periodic task's statistics over a phase."""

    name: str
    rate_hz: float
    runs: int
    overruns: int
    budget_exceeded: int
    jitter_p99_s: float
    jitter_p999_s: float
    jitter_max_s: float
    spent_s: float

    @classmethod
    def of(cls, task: PeriodicTask, stats: TaskStats) -> TaskFigures:
        return cls(
            name=task.spec.name,
            rate_hz=task.spec.rate_hz,
            runs=stats.runs,
            overruns=stats.overruns,
            budget_exceeded=stats.budget_exceeded,
            jitter_p99_s=stats.jitter_percentile_s(0.99),
            jitter_p999_s=stats.jitter_percentile_s(0.999),
            jitter_max_s=stats.max_jitter_s,
            spent_s=stats.spent_s,
        )


@dataclass(frozen=True, slots=True)
class PhaseResult:
    """Everything one phase measured."""

    name: str
    duration_s: float
    flood_load: float | None
    cpu_share: float
    sim_cpu_share: float
    bus_load: float
    can_latency: LatencySummary
    ibus_latency: LatencySummary
    tasks: tuple[TaskFigures, ...]
    stops: int
    steal_share: float = 0.0
    """CPU time the hypervisor took, as a share of one CPU (the machine's, not this process's)."""
    cpu_pressure_share: float = 0.0
    """Share of the time some task on the machine waited for a CPU (PSI "some")."""

    @property
    def control_tasks(self) -> tuple[TaskFigures, ...]:
        """The 100 Hz tasks (steering, driving, hydraulic brake)."""
        return tuple(task for task in self.tasks if task.rate_hz == CONTROL_RATE_HZ)

    @property
    def controller_cpu_share(self) -> float:
        """Share of one core the controller took: the process's less the simulator's."""
        return self.cpu_share - self.sim_cpu_share

    @property
    def tasks_share(self) -> float:
        """Share of one core the periodic tasks' own code took (the simulator's not counted)."""
        return sum(task.spent_s for task in self.tasks) / self.duration_s


def in_span(time_s: float, span: tuple[float, float]) -> bool:
    return span[0] <= time_s < span[1]


def latency_in(
    commands: Sequence[SentCommand],
    writes: Sequence[DacWrite],
    span: tuple[float, float],
    tolerance_volts: float,
) -> LatencySummary:
    """Latency summary of the commands completed within ``span``."""
    pairing = pairing_in(commands, writes, span, tolerance_volts)
    return summarise(pairing.latencies_s, pairing.unpaired)


def pairing_in(
    commands: Sequence[SentCommand],
    writes: Sequence[DacWrite],
    span: tuple[float, float],
    tolerance_volts: float,
) -> Pairing:
    """The commands completed within ``span``, each with its write."""
    chosen = [command for command in commands if in_span(command.completed_s, span)]
    return pair_writes(chosen, writes, tolerance_volts=tolerance_volts)


def latency_intervals(pairing: Pairing) -> list[tuple[float, float]]:
    """(completed, written) of every paired command."""
    return [(command.completed_s, write.time_s) for command, write in pairing.pairs if write]


def stops_in(mode_log: Sequence[tuple[float, ControlMode]], span: tuple[float, float]) -> int:
    """How often the robot fell to STOP within ``span`` (none is expected while benchmarking)."""
    return sum(mode is ControlMode.STOP and in_span(at_s, span) for at_s, mode in mode_log)
