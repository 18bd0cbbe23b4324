"""`bywire bench`: measures REQUIREMENTS §8's figures on the simulated robot and prints a table."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from bywire.bench import builds
from bywire.bench.clocks import MeteredRealtimeClock
from bywire.bench.figures import BenchResult, as_json
from bywire.bench.machine import machine_info
from bywire.bench.realtime_session import BenchSettings, RealtimeSession
from bywire.bench.realtime_session import Progress as ProgressCallback
from bywire.bench.secoc import measure_secoc_cost
from bywire.bench.table import render, render_tail, summary_line
from bywire.bench.tail import ProbedClock
from bywire.bench.virtual import measure_speedup, measure_verify_rate
from bywire.cli.console import stdout_console
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.errors import ConfigError
from bywire.runtime.realtime import RealtimeReport, apply_collector, apply_process
from bywire.sim.catalog import DEFAULT_SCENARIO

QUICK_PHASE_S = 1.0
QUICK_COURSE_S = 10.0
VERIFY_CAMPAIGNS = 100  # bywire verify's ten-second campaigns timed on every core
QUICK_CAMPAIGNS = 8
SECOC_SAMPLES = 20_000
QUICK_SECOC_SAMPLES = 2_000
MAX_PHASE_S = 3600.0


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the options of `bywire bench`."""
    parser.epilog = (
        "Runs the controller on the simulated robot in real time: a nominal phase and a phase"
        " with the CAN bus flooded by other nodes, each first driven over CAN and then by RC,"
        ' and the flood phase again with authenticated commands (SecOC: "secoc_flood");'
        " then the test course in virtual time. Exit status 0 whether or not targets are met."
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="real time per phase (default 60, as §8's 'over a minute' asks)",
    )
    parser.add_argument(
        "--flood-load",
        type=float,
        default=1.0,
        metavar="SHARE",
        help="share of the 500 kbit/s bus the other nodes fill in the flood phase (default 1.0)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"smoke run: {QUICK_PHASE_S:g} s phases and {QUICK_COURSE_S:g} s of the course",
    )
    parser.add_argument("--config", type=Path, metavar="FILE", help="robot TOML (default: sim)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument(
        "--realtime",
        action="store_true",
        help="apply the configuration's [realtime] settings (SCHED_FIFO, mlockall, CPUs, gc) to"
        " the benchmark's process first, as `bywire run` does; bench/realtime.toml turns each on",
    )
    parser.add_argument(
        "--look",
        action="store_true",
        help="also measure the cost of looking: a phase with the telemetry feed on and a"
        " Foxglove client (a process of its own) attached, and a phase with `bywire dashboard`"
        " as a child process on the feed, each at nominal load",
    )
    parser.add_argument(
        "--builds",
        metavar="PYTHON,PYTHON",
        help="instead: measure two or more installs of bywire side by side, each in its own"
        " Python (e.g. .venv/bin/python,.venv-c/bin/python: the pure and the compiled build):"
        " the test course and a fixed verify budget, interleaved A B A B ..., as x real time"
        " and campaigns per CPU-minute, with the ratios to the first",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        metavar="N",
        help=f"with --builds: runs of every build (default {builds.ROUNDS},"
        f" {builds.QUICK_ROUNDS} with --quick)",
    )
    parser.add_argument(
        "--budget",
        type=int,
        metavar="N",
        help=f"with --builds: verify campaigns per build per round (default {builds.BUDGET},"
        f" {builds.QUICK_BUDGET} with --quick)",
    )
    parser.add_argument(
        "--probe",
        action="store_true",
        help="also find where the tail comes from: time every garbage collection and sample the"
        " controller thread's CPU time and run-queue delay at each wait and sleep (costs CPU and"
        " memory: the probed run's CPU and memory figures are not the benchmark's)",
    )


def _settings(args: argparse.Namespace) -> BenchSettings:
    if args.rounds is not None or args.budget is not None:
        raise ConfigError("--rounds and --budget go with --builds")
    phase_s = QUICK_PHASE_S if args.quick else args.duration
    if not (math.isfinite(phase_s) and 0.5 <= phase_s <= MAX_PHASE_S):
        raise ConfigError(f"--duration {phase_s:g}: use 0.5 to {MAX_PHASE_S:g} seconds")
    if not 0.0 < args.flood_load <= 1.0:
        raise ConfigError(f"--flood-load {args.flood_load:g}: use a share in (0, 1]")
    return BenchSettings(phase_s=phase_s, flood_load=args.flood_load, look=args.look)


def run(args: argparse.Namespace) -> int:
    """Measure, then print the table (or JSON); 0 whatever the figures are."""
    if args.builds is not None:
        return _run_builds(args)
    settings = _settings(args)
    robot: RobotConfig = default_sim_config() if args.config is None else load_config(args.config)
    course_s = QUICK_COURSE_S if args.quick else None
    machine = machine_info()
    console = Console(stderr=True)
    clock = ProbedClock() if args.probe else MeteredRealtimeClock()
    applied = RealtimeReport()
    if args.realtime:
        applied = apply_process(robot.realtime, python=sys.executable)
    phases = (4 if settings.look else 2) + 1  # and the authenticated session's phase
    with _progress(console, phases * settings.phase_s) as progress:
        session = RealtimeSession(robot, settings, clock, progress)
        collector = apply_collector(robot.realtime, session.runtime) if args.realtime else None
        if collector is not None:
            applied.extend(collector.report)
        for refusal in applied.refused:
            console.print(f"bywire bench: warning: {refusal}", highlight=False)
        if args.realtime:
            console.print(f"bywire bench: {applied.line()}", highlight=False)
        if isinstance(clock, ProbedClock):
            clock.start()
        try:
            realtime = session.run()
            secured = RealtimeSession(robot, settings, clock, progress, authenticated=True)
            realtime = realtime.then(secured.run())
        finally:
            if isinstance(clock, ProbedClock):
                clock.stop()
            if collector is not None:
                collector.release()  # the virtual-time course runs with Python's own collector
        progress("virtual-time course", phases * settings.phase_s, phases * settings.phase_s)
        speedup = measure_speedup(robot, DEFAULT_SCENARIO, course_s)
        campaigns = QUICK_CAMPAIGNS if args.quick else VERIFY_CAMPAIGNS
        progress("verify campaigns", phases * settings.phase_s, phases * settings.phase_s)
        verify_rate = measure_verify_rate(robot, campaigns, os.cpu_count() or 1)
        progress("SecOC verification", 2 * settings.phase_s, 2 * settings.phase_s)
        secoc = measure_secoc_cost(
            QUICK_SECOC_SAMPLES if args.quick else SECOC_SAMPLES, robot.can.bitrate_bps
        )
    result = BenchResult(
        realtime=realtime,
        speedup=speedup,
        verify_rate=verify_rate,
        machine=machine,
        secoc=secoc,
        settings={
            "phase_s": settings.phase_s,
            "flood_load": settings.flood_load,
            "settle_s": settings.settle_s,
            "quick": bool(args.quick),
            "config": None if args.config is None else str(args.config),
            "course_duration_s": speedup.simulated_s,
            "probe": bool(args.probe),
            "look": bool(args.look),
            "realtime": applied.as_json() if args.realtime else None,
        },
    )
    if args.json:
        print(json.dumps(as_json(result), indent=2))
    else:
        out = stdout_console()
        out.print(render(result))
        out.print(summary_line(result))
        if realtime.tail is not None:
            out.print(render_tail(realtime.tail))
    return 0


def _given(value: int | None, default: int) -> int:
    return default if value is None else value


def _run_builds(args: argparse.Namespace) -> int:
    """`--builds`: the course and verify in every build, interleaved; the figures side by side."""
    pythons = builds.parse_builds(args.builds)
    for flag in ("look", "probe", "realtime"):
        if getattr(args, flag):
            raise ConfigError(f"--{flag} does not go with --builds (the course and verify only)")
    quick = bool(args.quick)
    settings = builds.BuildsSettings(
        rounds=_given(args.rounds, builds.QUICK_ROUNDS if quick else builds.ROUNDS),
        budget=_given(args.budget, builds.QUICK_BUDGET if quick else builds.BUDGET),
        course_s=QUICK_COURSE_S if quick else None,
        config=args.config,
    )
    console = Console(stderr=True)

    def progress(number: int, of: int, label: str, build: builds.Build) -> None:
        console.print(
            f"bywire bench: run {number + 1}/{of}: {label}, {build.build} ({build.python})",
            highlight=False,
        )

    result = builds.measure_builds(pythons, settings.checked(), progress)
    if args.json:
        print(json.dumps(builds.as_json(result), indent=2))
    else:
        stdout_console().print(builds.render(result), highlight=False, soft_wrap=True)
    return 0


@contextmanager
def _progress(console: Console, total_s: float) -> Iterator[ProgressCallback]:
    """A progress callback on stderr: a bar on a terminal, a line per stage otherwise.

    The bar refreshes only when called (no refresh thread), so it does not compete with the
    controller's loop for the interpreter.
    """
    console.print(
        f"bywire bench: {total_s:g} s in real time, then the {DEFAULT_SCENARIO} in virtual time",
        highlight=False,
    )
    if not console.is_terminal:
        yield _stage_lines(console)
        return
    columns = (TextColumn("{task.description:<20}"), BarColumn(), TextColumn("{task.fields[done]}"))
    with Progress(*columns, console=console, auto_refresh=False, transient=True) as bar:
        task = bar.add_task("nominal", total=total_s, done="")

        def update(stage: str, done_s: float, all_s: float) -> None:
            bar.update(task, description=stage, completed=done_s, done=f"{done_s:.0f}/{all_s:g} s")
            bar.refresh()

        yield update


def _stage_lines(console: Console) -> Callable[[str, float, float], None]:
    stages: list[str] = []

    def update(stage: str, done_s: float, all_s: float) -> None:
        if not stages or stages[-1] != stage:
            stages.append(stage)
            console.print(f"  {stage} ({done_s:.0f}/{all_s:g} s)", highlight=False)

    return update
