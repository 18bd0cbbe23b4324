"""`bywire bench --builds`: two or more installs of bywire (the pure and the compiled build, issue
43) measured side by side in one run, each in its own Python.

Every round runs each build once, in the order given (A B A B …, so a change in the machine's
load hits every build alike), as a child process of that build's Python: the test course in
virtual time, then a fixed budget of `bywire verify`'s campaigns in that one process. The child
times both on the wall clock and on its own CPU time; the figures add up the rounds, and each
build's is given beside the first build's as a ratio (with the lowest and highest round's, to
show the spread). Campaigns per CPU-minute is the figure that the machine's other load changes
least: it counts the time the campaigns ran, not the time they waited for a CPU.

The child is `PYTHON -P -m bywire.bench.builds measure …`, printing one JSON object; `describe`
says which bywire that Python imports. The same package twice is refused (it would measure
nothing); two installs of the same code are not (an A/A run shows the noise).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import bywire
from bywire.background import OWNER
from bywire.bench.machine import machine_info
from bywire.build import build_name
from bywire.config import default_sim_config, load_config
from bywire.errors import ConfigError
from bywire.sim.catalog import DEFAULT_SCENARIO, packaged_scenario
from bywire.sim.runner import SimRun
from bywire.sim.verify.draw import CAMPAIGN_S
from bywire.sim.verify.engine import CampaignJob, campaign_outcomes

CHILD_MODULE = "bywire.bench.builds"
LABELS = "ABCDEFGH"
MAX_BUILDS = len(LABELS)
ROUNDS = 3
QUICK_ROUNDS = 2
MAX_ROUNDS = 100
BUDGET = 20
"""verify campaigns per build per round: about 7 s of one core for the pure build."""
QUICK_BUDGET = 2
MAX_BUDGET = 10_000
DESCRIBE_TIMEOUT_S = 120.0


class BuildError(ConfigError):
    """A Python given to --builds that cannot be measured: none, no bywire, or one given twice."""


@dataclass(frozen=True, slots=True)
class Build:
    """What a Python given to --builds imports: its bywire's build and where that package is."""

    python: str
    """As given on the command line."""
    build: str
    """`bywire.build.build_name()`: 'pure' or 'compiled (mypyc X, -On)'."""
    package: str
    """The real path of the bywire package that Python imports."""
    version: str
    python_version: str


@dataclass(frozen=True, slots=True)
class RoundFigures:
    """One child run: build `build` (an index into the builds) in round `round` (from 0)."""

    build: int
    round: int
    course_simulated_s: float
    course_wall_s: float
    course_cpu_s: float
    campaigns: int
    verify_wall_s: float
    verify_cpu_s: float
    load_1m: float | None
    """The machine's 1-minute load average when the child finished."""


@dataclass(frozen=True, slots=True)
class BuildFigures:
    """A build's rounds added up."""

    course_x_realtime: float
    """Simulated over wall seconds of the test course: what `bywire bench` calls its speed-up."""
    course_x_cpu: float
    """Simulated seconds per CPU second of the course."""
    campaigns_per_cpu_minute: float
    campaigns_per_wall_minute: float


FIGURES = (
    ("course_x_realtime", "test course, x real time (wall)"),
    ("course_x_cpu", "test course, simulated s per CPU s"),
    ("campaigns_per_cpu_minute", "verify campaigns per CPU-minute"),
    ("campaigns_per_wall_minute", "verify campaigns per wall-minute (1 process)"),
)
"""Each figure's field of BuildFigures and its row in the table."""


def parse_builds(text: str) -> list[str]:
    """The Pythons of `--builds PYTHON,PYTHON[,…]`: two or more, none empty."""
    pythons = [part.strip() for part in text.split(",")]
    if any(not python for python in pythons):
        raise ConfigError(f"--builds {text!r}: an empty Python; give PYTHON,PYTHON[,...]")
    if not 2 <= len(pythons) <= MAX_BUILDS:
        raise ConfigError(
            f"--builds {text!r}: give 2 to {MAX_BUILDS} Pythons, comma-separated"
            " (e.g. .venv/bin/python,.venv-c/bin/python)"
        )
    return pythons


@dataclass(frozen=True, slots=True)
class BuildsSettings:
    """What every build runs, and how often."""

    rounds: int
    budget: int
    """verify campaigns per build per round."""
    course_s: float | None
    """Simulated seconds of the test course per run; None: the whole course."""
    config: Path | None
    """The robot file (default: the simulator's)."""

    def checked(self) -> BuildsSettings:
        """These settings; ConfigError naming `--rounds` or `--budget` outside its range."""
        if not 1 <= self.rounds <= MAX_ROUNDS:
            raise ConfigError(f"--rounds {self.rounds}: use 1 to {MAX_ROUNDS}")
        if not 1 <= self.budget <= MAX_BUDGET:
            raise ConfigError(f"--budget {self.budget}: use 1 to {MAX_BUDGET} campaigns per round")
        return self


def schedule(builds: int, rounds: int) -> list[tuple[int, int]]:
    """(round, build) in the order they run: every build once per round, in the order given."""
    return [(round_, build) for round_ in range(rounds) for build in range(builds)]


def distinct(builds: Sequence[Build]) -> None:
    """BuildError when two Pythons import the same bywire package."""
    seen: dict[str, Build] = {}
    for build in builds:
        first = seen.setdefault(build.package, build)
        if first is not build:
            raise BuildError(
                f"--builds: {first.python} and {build.python} run the same bywire"
                f" ({build.package}, {build.build}): give two different builds"
            )


def totals(figures: Sequence[RoundFigures], build: int) -> BuildFigures:
    """Build `build`'s rounds added up: simulated, wall and CPU time, campaigns."""
    mine = [f for f in figures if f.build == build]
    simulated = sum(f.course_simulated_s for f in mine)
    campaigns = sum(f.campaigns for f in mine)
    return BuildFigures(
        course_x_realtime=simulated / sum(f.course_wall_s for f in mine),
        course_x_cpu=simulated / sum(f.course_cpu_s for f in mine),
        campaigns_per_cpu_minute=campaigns * 60.0 / sum(f.verify_cpu_s for f in mine),
        campaigns_per_wall_minute=campaigns * 60.0 / sum(f.verify_wall_s for f in mine),
    )


def round_ratios(figures: Sequence[RoundFigures], build: int, name: str) -> list[float]:
    """Figure `name` of build `build` over the first build's, round by round."""
    by_round: dict[int, dict[int, RoundFigures]] = {}
    for f in figures:
        by_round.setdefault(f.round, {})[f.build] = f
    ratios = []
    for runs in by_round.values():
        if build in runs and 0 in runs:
            ours = getattr(totals([runs[build]], build), name)
            theirs = getattr(totals([runs[0]], 0), name)
            ratios.append(ours / theirs)
    return ratios


@dataclass(frozen=True, slots=True)
class BuildsResult:
    """A --builds run: the builds, each child run in the order it ran, and how it was set."""

    builds: tuple[Build, ...]
    runs: tuple[RoundFigures, ...]
    course_s: float | None
    """Simulated seconds of the course per run; None: the whole course."""
    budget: int
    machine: dict[str, object]

    def figures(self, build: int) -> BuildFigures:
        return totals(self.runs, build)


def as_json(result: BuildsResult) -> dict[str, Any]:
    """Every build with its figures and ratios to the first, and every run in order."""
    first = result.figures(0)
    builds = []
    for index, build in enumerate(result.builds):
        figures = result.figures(index)
        builds.append(
            {
                "label": LABELS[index],
                **asdict(build),
                "figures": asdict(figures),
                "ratio_to_A": {
                    name: getattr(figures, name) / getattr(first, name) for name, _ in FIGURES
                },
            }
        )
    return {
        "builds": builds,
        "runs": [asdict(run) for run in result.runs],
        "course_s": result.course_s,
        "verify_campaigns_per_run": result.budget,
        "machine": result.machine,
    }


def render(result: BuildsResult) -> str:
    """The figures of every build, each column headed by its label and build, ratios to A."""
    rounds = 1 + max(run.round for run in result.runs)
    loads = [run.load_1m for run in result.runs if run.load_1m is not None]
    load = f"; load (1 min) {min(loads):.2f} to {max(loads):.2f}" if loads else ""
    course = "the whole test course" if result.course_s is None else f"{result.course_s:g} s"
    lines = [
        f"bywire bench --builds: {rounds} round(s) of {course} and {result.budget} verify"
        f" campaign(s) per build, interleaved ({' '.join(LABELS[: len(result.builds)])} ...)"
        f"{load}",
    ]
    for index, build in enumerate(result.builds):
        lines.append(
            f"  {LABELS[index]}: {build.build} build, bywire {build.version},"
            f" Python {build.python_version}: {build.python} ({build.package})"
        )
    width = max(len(title) for _, title in FIGURES)
    header = "".join(
        f"  {LABELS[i]} ({build.build.split(' ')[0]})".rjust(16)
        for i, build in enumerate(result.builds)
    )
    ratios = "".join(f"{LABELS[i]}/A".rjust(22) for i in range(1, len(result.builds)))
    lines.append(f"{'':{width}}{header}{ratios}")
    for name, title in FIGURES:
        values = "".join(
            f"{getattr(result.figures(i), name):16.1f}" for i in range(len(result.builds))
        )
        spreads = ""
        for i in range(1, len(result.builds)):
            ratio = getattr(result.figures(i), name) / getattr(result.figures(0), name)
            per_round = round_ratios(result.runs, i, name)
            spreads += f"{ratio:8.2f} ({min(per_round):.2f}-{max(per_round):.2f})".rjust(22)
        lines.append(f"{title:{width}}{values}{spreads}")
    return "\n".join(lines)


def _child(python: str, arguments: Sequence[str], timeout_s: float | None) -> dict[str, Any]:
    """Run `python -P -m bywire.bench.builds ARGUMENTS` and read its one JSON line."""
    try:
        process = OWNER.popen(  # owned: a Ctrl-C or a failed run ends it (issue 42)
            [python, "-P", "-m", CHILD_MODULE, *arguments],
            name="bywire-bench-build",
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
    except OSError as error:
        raise BuildError(f"--builds: cannot run {python}: {error.strerror or error}") from None
    try:
        stdout, stderr = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        raise
    done = subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(nothing on stderr)"])[-1]
        if "No module named 'bywire'" in last:
            raise BuildError(f"--builds: {python} has no bywire installed ({last})")
        if f"No module named {CHILD_MODULE!r}" in last:
            raise BuildError(f"--builds: {python}'s bywire is older than bench --builds ({last})")
        raise BuildError(f"--builds: {python} {' '.join(arguments)} failed: {last}")
    reply: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return reply


def describe(python: str) -> Build:
    """Which bywire `python` imports (BuildError: none, or it cannot run)."""
    reply = _child(python, ["describe"], DESCRIBE_TIMEOUT_S)
    return Build(python=python, **reply)


Progress = Callable[[int, int, str, Build], None]
"""Called before each run: its number (from 0), how many there are, the build's label, the build."""


def measure_builds(
    pythons: Sequence[str], settings: BuildsSettings, progress: Progress
) -> BuildsResult:
    """Describe every Python, refuse the same package twice, then run the rounds interleaved."""
    builds = tuple(describe(python) for python in pythons)
    distinct(builds)
    arguments = ["measure", "--budget", str(settings.budget)]
    if settings.course_s is not None:
        arguments += ["--course-s", repr(settings.course_s)]
    if settings.config is not None:
        arguments += ["--config", str(settings.config.resolve())]
    runs = []
    order = schedule(len(builds), settings.rounds)
    for number, (round_, index) in enumerate(order):
        progress(number, len(order), LABELS[index], builds[index])
        reply = _child(builds[index].python, arguments, None)
        runs.append(RoundFigures(build=index, round=round_, **reply))
    return BuildsResult(builds, tuple(runs), settings.course_s, settings.budget, machine_info())


# --- the child: runs in the Python being measured ---------------------------------------------


def _describe_here() -> dict[str, Any]:
    return {
        "build": build_name(),
        "package": str(Path(bywire.__file__).resolve().parent),
        "version": bywire.__version__,
        "python_version": platform.python_version(),
    }


def _measure_here(budget: int, course_s: float | None, config: Path | None) -> dict[str, Any]:
    """The course, then `budget` campaigns in this one process, each on wall and CPU time."""
    robot = default_sim_config() if config is None else load_config(config)
    scenario = packaged_scenario(DEFAULT_SCENARIO)
    wall_0, cpu_0 = time.perf_counter(), time.process_time()
    run = SimRun(robot, scenario, duration_s=course_s)
    run.run()
    wall_1, cpu_1 = time.perf_counter(), time.process_time()
    outcomes = list(campaign_outcomes(robot, CampaignJob(0, CAMPAIGN_S), 1, budget, None))
    wall_2, cpu_2 = time.perf_counter(), time.process_time()
    return {
        "course_simulated_s": run.duration_s,
        "course_wall_s": wall_1 - wall_0,
        "course_cpu_s": cpu_1 - cpu_0,
        "campaigns": len(outcomes),
        "verify_wall_s": wall_2 - wall_1,
        "verify_cpu_s": cpu_2 - cpu_1,
        "load_1m": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }


def child_main(argv: Sequence[str]) -> int:
    """`python -m bywire.bench.builds describe|measure …`: one JSON line on stdout."""
    parser = argparse.ArgumentParser(prog=f"python -m {CHILD_MODULE}")
    parser.add_argument("what", choices=("describe", "measure"))
    parser.add_argument("--budget", type=int, default=BUDGET)
    parser.add_argument("--course-s", type=float, default=None)
    parser.add_argument("--config", type=Path, default=None)
    args = parser.parse_args(argv)
    if args.what == "describe":
        reply = _describe_here()
    else:
        reply = _measure_here(args.budget, args.course_s, args.config)
    print(json.dumps(reply))
    return 0


if __name__ == "__main__":
    sys.exit(child_main(sys.argv[1:]))
