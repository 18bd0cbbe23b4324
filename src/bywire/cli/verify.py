"""`bywire verify`: an adversarial safety campaign on your own robot configuration.

Random fault campaigns (every action and fault the scenarios know: sticks, switches and their
chatter, RC loss, failsafe, implausible and garbled frames, CAN silence, corruption, a second
sender, a pulled cable and a flooded bus, remote stops and re-enables, DAC NAKs and stalls inside
a write, dead sensors, failing brakes and steering), partly strung into episodes (a fault that
ends, then a re-arming; a broken brake or servo, then a request that needs it; a brake asked
with the throttle held, a reversal while rolling, a stop with the steering turned), run on the
simulated robot built from the configuration, in virtual time, on every core. After every pass
of the control loop the hazard oracle checks the output invariants H1–H10 of docs/SAFETY.md on
the simulated hardware.

A violation is shrunk to a short scenario written to --out; `bywire sim --scenario FILE` replays
it and fails. Exit status: 0 clean, 1 a violation or an unsafe combination of numbers, 2 a bad
configuration or argument.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from bywire.cli.arguments import positive_seconds, whole_number
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.config.deadlines import loss_distances, loss_rows
from bywire.hal.hardware import sensors_fitted
from bywire.sim.scenario import scenario_toml
from bywire.sim.verify.draw import CAMPAIGN_S
from bywire.sim.verify.engine import (
    CampaignJob,
    Outcome,
    Reproduction,
    campaign_outcomes,
    shrink_failure,
)
from bywire.sim.verify.oracle import INVARIANTS
from bywire.sim.verify.supervisor_check import MONITOR_CAUSES, TRANSITIONS, transitions_naming

DEFAULT_BUDGET = 200
DEFAULT_OUT = Path("verify-failures")


_positive_int = whole_number(1)
_seed = whole_number(0)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = "\n\n".join((__doc__ or "").split("\n\n")[1:]).strip()
    parser.epilog = (
        "Examples: `bywire verify` (the simulator's configuration, 200 campaigns); "
        "`bywire verify --config robot.toml --duration 600` (ten minutes on every core). "
        "The same --seed and --budget give the same campaigns and the same result."
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="robot configuration TOML to verify (default: the packaged simulator defaults)",
    )
    amount = parser.add_mutually_exclusive_group()
    amount.add_argument(
        "--budget",
        type=_positive_int,
        metavar="N",
        help=f"run N campaigns (default {DEFAULT_BUDGET})",
    )
    amount.add_argument(
        "--duration",
        type=positive_seconds,
        metavar="S",
        help="run campaigns for S seconds of wall time instead of a fixed number",
    )
    parser.add_argument(
        "--jobs",
        type=_positive_int,
        metavar="N",
        default=os.cpu_count() or 1,
        help="processes to run campaigns in (default: every core, %(default)s here)",
    )
    parser.add_argument(
        "--seed", type=_seed, default=0, metavar="S", help="random seed (default 0)"
    )
    parser.add_argument(
        "--campaign-s",
        type=positive_seconds,
        default=CAMPAIGN_S,
        metavar="S",
        help=f"simulated seconds per campaign (default {CAMPAIGN_S:g})",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"where a failure's scenario TOML is written (default ./{DEFAULT_OUT})",
    )
    parser.add_argument(
        "--keep-going",
        action="store_true",
        help="run the campaigns even when the configuration is unsafe by construction",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


@dataclass(slots=True)
class Tally:
    """What the campaigns did, added up."""

    campaigns: int = 0
    simulated_s: float = 0.0
    events: int = 0
    checks: int = 0
    violations: Counter[str] = field(default_factory=Counter)
    transitions: set[str] = field(default_factory=set)
    failing: dict[str, Outcome] = field(default_factory=dict)  # the first campaign per invariant

    def add(self, outcome: Outcome) -> None:
        self.campaigns += 1
        self.simulated_s += outcome.simulated_s
        self.events += outcome.events
        self.checks += outcome.checks
        self.transitions |= outcome.transitions
        for invariant in {finding.invariant for finding in outcome.findings}:
            self.violations[invariant] += 1
            first = self.failing.get(invariant)
            if first is None or outcome.index < first.index:
                self.failing[invariant] = outcome


def _progress(console: Console, show: bool) -> Progress:
    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
        console=console,
        disable=not show,
        transient=True,
    )


def run(args: argparse.Namespace) -> int:
    robot = default_sim_config() if args.config is None else load_config(args.config)
    source = str(args.config) if args.config is not None else "the simulator's defaults"
    console = Console(stderr=True)
    show = sys.stderr.isatty() and not args.json
    budget = args.budget if args.budget is not None or args.duration else DEFAULT_BUDGET
    until = None if args.duration is None else time.monotonic() + args.duration
    job = CampaignJob(args.seed, args.campaign_s)
    tally = Tally()
    started = time.perf_counter()
    with _progress(console, show) as progress:
        task = progress.add_task("campaigns", total=budget, status="")
        for outcome in campaign_outcomes(robot, job, args.jobs, budget, until):
            tally.add(outcome)
            status = ", ".join(f"{k} {n}" for k, n in sorted(tally.violations.items()))
            progress.update(task, advance=1, status=status or "0 violations")
    wall_s = time.perf_counter() - started
    reproductions = _shrink_all(robot, tally, args, console, show)
    summary = _summary(
        source, args, tally, wall_s, reproductions, cannot_happen=_cannot_happen(robot)
    )
    summary["configuration"] = {"loss_distances": loss_rows(robot)}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        _print_summary(Console(), summary, robot)
    return 1 if tally.violations else 0


def _shrink_all(
    robot: RobotConfig,
    tally: Tally,
    args: argparse.Namespace,
    console: Console,
    show: bool,
) -> list[Reproduction]:
    """Shrink the first failing campaign of each broken invariant and write its scenario."""
    reproductions = []
    if tally.failing:
        args.out.mkdir(parents=True, exist_ok=True)
    for invariant, outcome in sorted(tally.failing.items()):
        name = f"verify-seed{args.seed}-campaign{outcome.index}-{invariant}"
        with _progress(console, show) as progress:
            task = progress.add_task(f"shrinking {invariant}", total=None, status="")

            def ran(runs: int, task: Any = task, progress: Progress = progress) -> None:
                progress.update(task, status=f"{runs} runs")

            found = shrink_failure(robot, outcome, invariant, name, on_run=ran)
        path = args.out / f"{name}.toml"
        replay = f"bywire sim --scenario {path}"
        if args.config is not None:
            replay += f" --config {args.config}"
        header = (
            f"Found by `bywire verify --seed {args.seed}` (campaign {outcome.index}),"
            f" shrunk from {found.original_steps} steps to {len(found.steps)}"
            f" in {found.shrink_runs} runs.\nReplay: {replay}\n"
            f"The expectation fails: {found.finding.invariant} of docs/SAFETY.md broke there."
        )
        path.write_text(scenario_toml(found.scenario, header), encoding="utf-8")
        found.notes.append(str(path))
        reproductions.append(found)
    return reproductions


def _cannot_happen(robot: RobotConfig) -> tuple[str, ...]:
    """The transitions this robot cannot take, so a campaign never missed them: without the
    sensors its backend does not fit, no monitor raises its causes."""
    return () if sensors_fitted(robot.backend) else transitions_naming(MONITOR_CAUSES)


def _summary(
    source: str,
    args: argparse.Namespace,
    tally: Tally,
    wall_s: float,
    reproductions: list[Reproduction],
    *,
    cannot_happen: tuple[str, ...],
) -> dict[str, Any]:
    possible = [label for label in TRANSITIONS if label not in cannot_happen]
    never = [label for label in possible if label not in tally.transitions]
    return {
        "config": source,
        "seed": args.seed,
        "jobs": args.jobs,
        "campaigns": tally.campaigns,
        "simulated_s": round(tally.simulated_s, 3),
        "wall_s": round(wall_s, 3),
        "campaigns_per_minute": round(tally.campaigns / wall_s * 60, 1) if wall_s else None,
        "speed_up": round(tally.simulated_s / wall_s, 1) if wall_s else None,
        "events_injected": tally.events,
        "invariant_checks": tally.checks * len(INVARIANTS),
        "passes_checked": tally.checks,
        "violations": {invariant: tally.violations[invariant] for invariant in INVARIANTS},
        "transitions": {
            "exercised": len(possible) - len(never),
            "of": len(possible),
            "never": never,
            "cannot_happen": list(cannot_happen),
            # A row taken that cannot happen is bywire's own bug (a monitor without its sensor).
            "cannot_happen_but_taken": [row for row in cannot_happen if row in tally.transitions],
        },
        "failures": [
            {
                "invariant": r.finding.invariant,
                "time_s": r.finding.time_s,
                "detail": r.finding.detail,
                "steps": len(r.steps),
                "shrunk_from": r.original_steps,
                "scenario": r.notes[0] if r.notes else None,
            }
            for r in reproductions
        ],
    }


def _print_summary(console: Console, summary: dict[str, Any], robot: RobotConfig) -> None:
    violations = summary["violations"]
    transitions = summary["transitions"]
    console.print(f"[bold]bywire verify[/bold] on {summary['config']} (seed {summary['seed']})")
    console.print("  configuration: what each timeout buys (at top speed, before the stop):")
    for loss in loss_distances(robot):
        console.print(f"    {loss}", highlight=False)
    console.print(
        f"  {summary['campaigns']} campaigns, {summary['simulated_s']:.0f} s simulated in"
        f" {summary['wall_s']:.1f} s on {summary['jobs']} processes"
        f" ({summary['campaigns_per_minute']} campaigns/min, {summary['speed_up']}x real time)"
    )
    console.print(
        f"  {summary['events_injected']} events injected, {summary['passes_checked']} passes"
        f" checked ({summary['invariant_checks']} invariant checks)"
    )
    shown = ", ".join(f"{name} {count}" for name, count in violations.items())
    console.print(f"  campaigns violating: {shown}")
    console.print(
        f"  supervisor transitions exercised: {transitions['exercised']} of {transitions['of']}"
    )
    for label in transitions["never"]:
        console.print(f"    never: {label}", highlight=False)
    if transitions["cannot_happen"]:
        console.print(
            f"  {len(transitions['cannot_happen'])} more cannot happen on this robot: its"
            " backend fits no brake-pressure or steering-encoder sensor, so no monitor raises"
            " them (docs/DEPLOY.md)",
            highlight=False,
        )
    for label in transitions["cannot_happen_but_taken"]:
        console.print(
            f"[red]  taken though it cannot happen on this robot: {label}[/red]"
            " (a bug of bywire's: please report it)",
            highlight=False,
        )
    for failure in summary["failures"]:
        console.print(
            f"[red]  {failure['invariant']} broken at {failure['time_s']:.3f} s:"
            f" {failure['detail']}[/red]; shrunk from {failure['shrunk_from']} steps to"
            f" {failure['steps']}: {failure['scenario']}",
            highlight=False,
        )
    verdict = "[red]VIOLATIONS[/red]" if any(violations.values()) else "[green]clean[/green]"
    console.print(f"  result: {verdict}")
