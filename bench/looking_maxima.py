"""Does looking move the maxima? The nominal and feed phases, repeated, compared as distributions.

One `bywire bench --look` run gives one maximum per phase, and on a shared VM two identical
phases' maxima differ by milliseconds (bench/RESULTS.md, runs I and J): a single pair cannot show
a difference of 0.1 ms either way. This script runs the bench's real-time session ROUNDS times
(each: nominal, flood, feed with a Foxglove client attached, dashboard child process) and prints,
for the nominal and the feed phase, every round's p99 and max of CAN → DAC and IBUS → DAC latency
and of the 100 Hz tasks' jitter, then each figure's median over the rounds and the feed phase's
difference from the nominal phase's:

    PYTHONPATH=src .venv/bin/python bench/looking_maxima.py --rounds 6 --phase-s 20 \\
        --config bench/realtime.toml --realtime

`--realtime` applies the configuration's `[realtime]` settings as `bywire bench --realtime` does.
A round takes 4 × PHASE_S seconds; progress goes to stderr, the table to stdout.
"""

from __future__ import annotations

import argparse
import gc
import itertools
import statistics
import sys
from pathlib import Path

from bywire.bench.clocks import MeteredRealtimeClock
from bywire.bench.figures import phase_figures
from bywire.bench.realtime_session import BenchSettings, RealtimeSession
from bywire.config import default_sim_config, load_config
from bywire.runtime.realtime import apply_collector, apply_process

PHASES = ("nominal", "feed")
FIGURES = (
    ("can_latency_p99_ms", "CAN p99"),
    ("can_latency_max_ms", "CAN max"),
    ("ibus_latency_p99_ms", "IBUS p99"),
    ("ibus_latency_max_ms", "IBUS max"),
    ("jitter_p99_ms", "jitter p99"),
    ("jitter_max_ms", "jitter max"),
)


def _round(robot_config: Path | None, phase_s: float, realtime: bool) -> dict[str, float]:
    robot = default_sim_config() if robot_config is None else load_config(robot_config)
    settings = BenchSettings(phase_s=phase_s, look=True)
    session = RealtimeSession(robot, settings, MeteredRealtimeClock())
    collector = apply_collector(robot.realtime, session.runtime) if realtime else None
    try:
        result = session.run()
    finally:
        if collector is not None:
            collector.release()
    figures: dict[str, float] = {}
    for phase in result.phases:
        if phase.name in PHASES:
            figures.update((f.key, f.value) for f in phase_figures(phase) if f.value is not None)
            figures[f"{phase.name}_stops"] = phase.stops
    del session, result
    gc.collect()  # the next round starts with no garbage of this one, as a fresh `bywire bench`
    return figures


def _median_of(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def _median(rounds: list[dict[str, float]], key: str) -> float | None:
    """Over the rounds that have the figure (a phase without samples has none)."""
    return _median_of([r[key] for r in rounds if key in r])


def _cell(value: float | None, sign: str = "") -> str:
    return "–" if value is None else f"{value:{sign}.2f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6, help="sessions to run (default 6)")
    parser.add_argument("--phase-s", type=float, default=20.0, help="seconds a phase (default 20)")
    parser.add_argument("--config", type=Path, help="robot TOML (default: simulator defaults)")
    parser.add_argument("--realtime", action="store_true", help="apply [realtime] as bench does")
    args = parser.parse_args()
    if args.rounds < 2 or args.phase_s < 5:
        parser.error("use --rounds ≥ 2 and --phase-s ≥ 5: a median of one round is no median")
    if args.realtime:
        robot = default_sim_config() if args.config is None else load_config(args.config)
        report = apply_process(robot.realtime, python=sys.executable)
        print(f"looking_maxima: {report.line()}", file=sys.stderr)
    header = (
        "| round | phase | "
        + " | ".join(label for _, label in FIGURES)
        + " | samples CAN/IBUS | falls to STOP |"
    )
    print(header)
    print("|---|---|" + "---:|" * (len(FIGURES) + 2), flush=True)
    rounds: list[dict[str, float]] = []
    for index in range(1, args.rounds + 1):
        print(f"looking_maxima: round {index}/{args.rounds}", file=sys.stderr, flush=True)
        figures = _round(args.config, args.phase_s, args.realtime)
        rounds.append(figures)
        for phase in PHASES:
            cells = " | ".join(_cell(figures.get(f"{phase}_{key}")) for key, _ in FIGURES)
            counts = "/".join(
                f"{figures.get(f'{phase}_{path}_latency_samples', 0):.0f}"
                for path in ("can", "ibus")
            )
            stops = f"{figures[f'{phase}_stops']:.0f}"
            print(f"| {index} | {phase} | {cells} | {counts} | {stops} |", flush=True)
    medians = {phase: [_median(rounds, f"{phase}_{key}") for key, _ in FIGURES] for phase in PHASES}
    for phase in PHASES:
        print(f"| median | {phase} | " + " | ".join(_cell(m) for m in medians[phase]) + " | | |")
    deltas = [
        None if f is None or n is None else f - n
        for f, n in zip(medians["feed"], medians["nominal"], strict=True)
    ]
    print("| median | feed − nominal | " + " | ".join(_cell(d, "+") for d in deltas) + " | | |")
    spread = [
        _median_of(
            [
                abs(a[k] - b[k])
                for a, b in itertools.pairwise(rounds)
                if (k := f"nominal_{key}") in a and k in b
            ]
        )
        for key, _ in FIGURES
    ]
    print(
        "| nominal, round to round | median change | "
        + " | ".join(_cell(s) for s in spread)
        + " | | |"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
