"""Where virtual time's wall time goes, and the speed-up it could reach at best.

`bywire bench` gives the test course's speed-up and `bywire verify`'s campaigns a minute as one
figure each. This splits a run's wall time between the parts that take turns on one thread: the
controller's own passes (those that decide and those that only read), the simulator's events
(what `VirtualClock.wait_until` runs: the transmitter, the computer, the bus, the vehicle), and
the observation after each pass (the scenario's expectations; a campaign's hazard oracle). The
*controller ceiling* is the speed-up if the simulator and the observation cost nothing: the
controller code alone at the rates the robot's inputs and tasks set, which no change to the
simulator can beat:

    PYTHONPATH=src .venv/bin/python bench/course_split.py --rounds 5
    PYTHONPATH=src .venv/bin/python bench/course_split.py --rounds 3 --campaigns 20

With `--campaigns N` the run is verify's first N campaigns of seed 0 on one process, and the
ceiling is also given as campaigns a minute on every core. The parts are timed by wrapping the
methods for the run (which adds its own cost, so the split run is slower than the plain one
printed beside it); the split is a median over `--rounds`.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import asdict, dataclass
from typing import Any

from bywire.bench.virtual import measure_speedup
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.runtime.loop import Runtime
from bywire.sim.runner import SimRun
from bywire.sim.verify.campaign import TransitionLog
from bywire.sim.verify.draw import draw_campaign
from bywire.sim.verify.engine import run_campaign
from bywire.sim.verify.oracle import HazardOracle

Workload = Callable[[], float]  # runs, returns the simulated seconds


@dataclass(slots=True)
class Split:
    """One run's wall time by part (seconds) and the passes it took."""

    simulated_s: float = 0.0
    wall_s: float = 0.0
    deciding_s: float = 0.0
    reading_s: float = 0.0  # passes that polled the inputs but did not decide
    simulator_s: float = 0.0
    observing_s: float = 0.0
    deciding_passes: int = 0
    reading_passes: int = 0

    @property
    def controller_s(self) -> float:
        return self.deciding_s + self.reading_s

    @property
    def ceiling(self) -> float:
        """The speed-up with a simulator and an observation that cost nothing."""
        return self.simulated_s / self.controller_s


@contextmanager
def _wrapped(owner: type, name: str, around: Callable[..., Any]) -> Iterator[None]:
    original = getattr(owner, name)

    def wrapper(self: object, *args: Any) -> Any:
        return around(original, self, *args)

    setattr(owner, name, wrapper)
    try:
        yield
    finally:
        setattr(owner, name, original)


def course(robot: RobotConfig) -> Workload:
    """The default test course, as `bywire bench` runs it."""
    return lambda: measure_speedup(robot).simulated_s


def campaigns(robot: RobotConfig, count: int) -> Workload:
    """`bywire verify`'s first `count` campaigns of seed 0, one after another."""

    def run() -> float:
        return sum(run_campaign(robot, draw_campaign(0, i), i).simulated_s for i in range(count))

    return run


def split_run(workload: Workload) -> tuple[float, Split]:
    """One plain run (its speed-up), then one with every part timed."""
    started = time.perf_counter()
    plain = workload() / (time.perf_counter() - started)
    split = Split()
    decisions = [0]

    def counted_decide(original: Callable[..., Any], runtime: Runtime, *args: Any) -> Any:
        decisions[0] += 1
        return original(runtime, *args)

    def timed_pass(original: Callable[..., Any], runtime: Runtime, *args: Any) -> Any:
        before, started = decisions[0], time.perf_counter()
        result = original(runtime, *args)
        spent = time.perf_counter() - started
        if decisions[0] > before:
            split.deciding_s += spent
            split.deciding_passes += 1
        else:
            split.reading_s += spent
            split.reading_passes += 1
        return result

    def timed(field: str) -> Callable[..., Any]:
        def around(original: Callable[..., Any], owner: object, *args: Any) -> Any:
            started = time.perf_counter()
            try:
                return original(owner, *args)
            finally:
                setattr(split, field, getattr(split, field) + time.perf_counter() - started)

        return around

    wrappers = (
        (Runtime, "_decide", counted_decide),
        (Runtime, "_pass", timed_pass),
        (VirtualClock, "wait_until", timed("simulator_s")),
        (SimRun, "_observe", timed("observing_s")),
        (HazardOracle, "observe", timed("observing_s")),
        (TransitionLog, "observe", timed("observing_s")),
    )
    with ExitStack() as stack:
        for owner, name, around in wrappers:
            stack.enter_context(_wrapped(owner, name, around))
        started = time.perf_counter()
        split.simulated_s = workload()
        split.wall_s = time.perf_counter() - started
    return plain, split


def _median_split(splits: list[Split]) -> dict[str, float]:
    fields = asdict(splits[0])
    median = {name: statistics.median(asdict(s)[name] for s in splits) for name in fields}
    median["controller_s"] = statistics.median(s.controller_s for s in splits)
    median["ceiling"] = statistics.median(s.ceiling for s in splits)
    return median


def _print(plain: list[float], split: dict[str, float], campaign_s: float | None) -> None:
    wall = split["wall_s"]
    print(f"{split['simulated_s']:.0f} s simulated")
    runs = " / ".join(f"{speedup:.1f}x" for speedup in plain)
    print(f"plain runs: {runs} (median {statistics.median(plain):.1f}x)")
    print(f"split run (timing wrappers on): {wall:.3f} s wall, medians:")
    parts = (
        ("passes that decide", split["deciding_s"], split["deciding_passes"]),
        ("passes that only read", split["reading_s"], split["reading_passes"]),
        ("simulator events", split["simulator_s"], 0),
        ("observation", split["observing_s"], 0),
    )
    for label, spent, passes in parts:
        each = f", {spent / passes * 1e6:.0f} µs each × {passes:.0f}" if passes else ""
        print(f"  {label:<24} {spent:6.3f} s  {100 * spent / wall:4.1f} %{each}")
    rest = wall - sum(spent for _, spent, _ in parts)
    print(f"  {'the loop and wrappers':<24} {rest:6.3f} s  {100 * rest / wall:4.1f} %")
    print(
        f"controller ceiling: {split['ceiling']:.1f}x "
        "(if the simulator and the observation cost nothing)"
    )
    if campaign_s is not None:
        per_minute = 60.0 * split["ceiling"] / campaign_s * (os.cpu_count() or 1)
        print(f"  as verify campaigns: {per_minute:.0f} a minute on {os.cpu_count()} cores at best")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="runs of each kind (5)")
    parser.add_argument("--config", help="a robot TOML (default: the simulator's)")
    parser.add_argument(
        "--campaigns", type=int, help="split this many of verify's campaigns, not the course"
    )
    parser.add_argument("--json", action="store_true", help="print the medians as JSON")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error(f"--rounds must be at least 1, got {args.rounds}")
    if args.campaigns is not None and args.campaigns < 1:
        parser.error(f"--campaigns must be at least 1, got {args.campaigns}")
    robot = default_sim_config() if args.config is None else load_config(args.config)
    workload = course(robot) if args.campaigns is None else campaigns(robot, args.campaigns)
    plain: list[float] = []
    splits: list[Split] = []
    for round_ in range(args.rounds):
        print(f"round {round_ + 1}/{args.rounds}", file=sys.stderr)
        speedup, split = split_run(workload)
        plain.append(speedup)
        splits.append(split)
    median = _median_split(splits)
    if args.json:
        print(json.dumps({"plain_speedups": plain, "split": median}, indent=2))
    else:
        campaign_s = None if args.campaigns is None else median["simulated_s"] / args.campaigns
        _print(plain, median, campaign_s)
    return 0


if __name__ == "__main__":
    sys.exit(main())
