"""What a pass of the control loop costs in the bench's real-time session; why some cost more.

`bywire bench --probe` explains which commands were late; this measures the loop itself: the
controller thread's CPU between two of its waits (one pass and its per-pass observers), the minor
page faults it took meanwhile, and each periodic task's own CPU, over the bench's nominal and flood
phases, then prints the distribution and the slowest passes:

    PYTHONPATH=src .venv/bin/python bench/pass_cost.py --phase-s 30 --config bench/realtime.toml

The configuration's `[realtime]` settings are applied as `bywire bench --realtime` does. An input
that arrives while a pass runs waits for the rest of it, so the passes over 0.5 ms are where
command → actuator latency's tail begins. A pass that took 256 minor faults mapped a new 1 MiB
arena of Python's allocator, which `lock_memory` (MCL_FUTURE) populates at once.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import resource
import sys
import time
from collections import defaultdict
from pathlib import Path

from bywire.bench.clocks import MeteredRealtimeClock
from bywire.bench.realtime_session import BenchSettings, RealtimeSession
from bywire.bench.stats import summarise
from bywire.config import default_sim_config, load_config
from bywire.control.controller import ControlOutputs
from bywire.runtime.loop import Runtime
from bywire.runtime.realtime import apply_collector, apply_process
from bywire.task_table import TaskFn

SLOW_S = 0.0005
SHOWN = 12


def _faults() -> int:
    return resource.getrusage(resource.RUSAGE_THREAD).ru_minflt


@dataclasses.dataclass(frozen=True, slots=True)
class Pass:
    at_s: float
    cpu_s: float
    faults: int
    tasks: tuple[str, ...]
    collected_s: float  # of cpu_s, in garbage collections (the idle collector runs after a pass)
    generation: int  # the oldest generation collected, or -1


class PassMeter(MeteredRealtimeClock):
    """The real-time clock, noting the controller thread's CPU and faults between two waits."""

    def __init__(self) -> None:
        super().__init__()
        self.passes: list[Pass] = []
        self.ran: list[str] = []  # the tasks of the pass under way
        self.collected_s = 0.0  # CPU in collections during the pass under way
        self.generation = -1
        self._collecting_since_s = 0.0
        self._left: tuple[float, float, int] | None = None
        gc.callbacks.append(self._collection)

    def _collection(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._collecting_since_s = time.thread_time()
            self.generation = max(self.generation, info["generation"])
        else:
            self.collected_s += time.thread_time() - self._collecting_since_s

    def wait_until(self, deadline_s: float) -> None:
        cpu_s, faults = time.thread_time(), _faults()
        if self._left is not None:
            at_s, left_cpu_s, left_faults = self._left
            spent_s, taken = cpu_s - left_cpu_s, faults - left_faults
            collected = (self.collected_s, self.generation)
            self.passes.append(Pass(at_s, spent_s, taken, tuple(self.ran), *collected))
        self.ran, self.collected_s, self.generation = [], 0.0, -1
        super().wait_until(deadline_s)
        self._left = (self.now(), time.thread_time(), _faults())


def _metered(run: TaskFn, name: str, meter: PassMeter, spent: dict[str, list[float]]) -> TaskFn:
    def metered(runtime: Runtime, outputs: ControlOutputs, now: float) -> None:
        started_s = time.thread_time()
        run(runtime, outputs, now)
        spent[name].append(time.thread_time() - started_s)
        meter.ran.append(name)

    return metered


def _quantiles(values: list[float]) -> str:
    summary = summarise(values)
    picked = (summary.p50_s, summary.p99_s, summary.p999_s, summary.max_s)
    p50, p99, p999, most = (value * 1e3 for value in picked if value is not None)
    return f"p50 {p50:.3f}  p99 {p99:.3f}  p99.9 {p999:.3f}  max {most:.3f} ms"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--phase-s", type=float, default=30.0, help="seconds per phase")
    parser.add_argument("--config", type=Path, help="robot TOML (default: the simulator's)")
    args = parser.parse_args()
    robot = default_sim_config() if args.config is None else load_config(args.config)
    applied = apply_process(robot.realtime, python=sys.executable)
    meter = PassMeter()
    session = RealtimeSession(robot, BenchSettings(phase_s=args.phase_s), meter)
    spent: dict[str, list[float]] = defaultdict(list)
    for task in session.runtime.tasks:
        task.spec = dataclasses.replace(
            task.spec, run=_metered(task.spec.run, task.spec.name, meter, spent)
        )
    collector = apply_collector(robot.realtime, session.runtime)
    applied.extend(collector.report)
    print(applied.line(), file=sys.stderr)
    try:
        session.run()
    finally:
        collector.release()
    passes = meter.passes
    slow = [p for p in passes if p.cpu_s > SLOW_S]
    faulted = [p for p in passes if p.faults]
    print(f"{len(passes)} passes: {_quantiles([p.cpu_s for p in passes])}")
    print(
        f"over {SLOW_S * 1e3:g} ms: {len(slow)} ({sum(1 for p in slow if p.faults)} with faults);"
        f" passes with faults: {len(faulted)}; peak RSS"
        f" {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.1f} MB"
    )
    for name, values in spent.items():
        print(f"  task {name:10s} {len(values):6d} runs: {_quantiles(values)}")
    for generation in (0, 1, 2):
        collections = [p.collected_s for p in passes if p.generation == generation]
        late = sum(1 for p in slow if p.generation == generation)
        if collections:
            print(
                f"  collections up to generation {generation}: {len(collections)},"
                f" {_quantiles(collections)}; {late} of them in a pass over {SLOW_S * 1e3:g} ms"
            )
    print("slowest passes (time in the session, CPU, of it collecting, faults, tasks run):")
    for p in sorted(passes, key=lambda p: -p.cpu_s)[:SHOWN]:
        tasks = ",".join(p.tasks) or "(an input only)"
        print(
            f"  {p.at_s:8.3f} s  {p.cpu_s * 1e3:.3f} ms  {p.collected_s * 1e3:.3f} ms"
            f" (gen {p.generation})"
            f"  {p.faults:4d}  {tasks}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
