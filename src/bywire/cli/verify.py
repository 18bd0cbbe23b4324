"""`bywire verify`: an adversarial safety campaign on your own robot configuration.

Random fault campaigns (every action and fault the scenarios know: sticks, switches and their
chatter, RC loss, failsafe, implausible and garbled frames, CAN silence, corruption, a second
sender, a pulled cable and a flooded bus, remote stops and re-enables, DAC NAKs and stalls inside
a write, dead sensors, failing brakes and steering), partly strung into episodes (a fault that
ends, then a re-arming; a broken brake or servo, then a request that needs it; a brake asked
with the throttle held, a reversal while rolling, a stop with the steering turned), run on the
simulated robot built from the configuration, in virtual time, on every core. After every pass
of the control loop the hazard oracle checks the output invariants H1–H11 of docs/SAFETY.md on
the simulated hardware. A fifth of the campaigns are bridge campaigns: the ROS 2 bridge's CAN
side (its link, speed loop, stop ramp and enabling) is the computer, fed by a simulated planner
(speeds, curvatures, reversals, silence, stale and lagging stamps, rates, ~/enable and
~/remote_stop) among the faults that matter to it (a dead wheel sensor, failing brakes, the
bridge falling silent, a pulled cable, RC taking over); besides H1–H11 they are judged on the
bridge's own invariants B1–B3 (a flagged speed ends in a stop, the stop ramp brakes to
standstill, every refused command shows in /diagnostics).

With --cluster the campaigns run on a Dask distributed cluster instead (`local`: one started on
127.0.0.1; tcp://HOST:PORT: a scheduler you run; README "Verifying on a cluster"), with the same
result for the same seed and budget. Wherever they run, a campaign that kills its worker twice
is reported (a crash), and with --jobs a campaign still running after --hang-s seconds of real
time is killed with its worker and reported (a hang); the run goes on. A cluster left with no
worker for a minute stops the run: what ran is summarised and shrunk, and the run is incomplete.

A violation is shrunk to a short scenario written to --out; `bywire sim --scenario FILE` replays
it and fails. Ctrl-C, or a SIGTERM (a batch scheduler's time limit, `timeout`, a service
manager), ends the campaigns: what ran is summarised and its violations shrunk all the same (a
second Ctrl-C skips that). Exit status: 0 clean, 1 a violation, a crash, a hang, an unsafe
combination of numbers or a run the cluster stopped, 2 a bad configuration or argument, 130
after Ctrl-C and 143 after SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Generator, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from bywire.cli.arguments import positive_seconds, whole_number
from bywire.config import RobotConfig, default_sim_config, load_config
from bywire.config.deadlines import loss_distances, loss_rows
from bywire.config.loader import DEFAULT_SIM_RESOURCE
from bywire.hal.hardware import sensors_fitted
from bywire.sim.scenario import scenario_toml
from bywire.sim.verify.campaign import Campaign
from bywire.sim.verify.cluster import (
    LOCAL,
    WORKERS_TIMEOUT_S,
    ClusterLostError,
    cluster_client,
    cluster_outcomes,
    robot_hash,
    worker_count,
)
from bywire.sim.verify.draw import CAMPAIGN_S
from bywire.sim.verify.engine import (
    HANG_S,
    INTERRUPTING,
    CampaignJob,
    Crash,
    Hang,
    Outcome,
    Reproduction,
    Result,
    campaign_outcomes,
    shrink_failure,
)
from bywire.sim.verify.oracle import INVARIANTS
from bywire.sim.verify.oracle.invariants import BRIDGE_INVARIANTS, OUTPUT_INVARIANTS
from bywire.sim.verify.robots import (
    DrawnRobot,
    Schema,
    draw_robots,
    keys_needed,
    robot_with,
    toml_value,
)
from bywire.sim.verify.supervisor_check import MONITOR_CAUSES, TRANSITIONS, transitions_naming
from bywire.textfile import read_text

if TYPE_CHECKING:
    from distributed import Client

DEFAULT_BUDGET = 200
DEFAULT_OUT = Path("verify-failures")


_positive_int = whole_number(1)
_seed = whole_number(0)


def _cluster_address(text: str) -> str:
    """`local` or a scheduler's address (tcp://HOST:PORT, tls://…)."""
    if text == LOCAL or ("://" in text and text.split("://", 1)[1]):
        return text
    raise argparse.ArgumentTypeError(
        f"{text!r}: give `local` or a scheduler's address, e.g. tcp://127.0.0.1:8786"
    )


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = "\n\n".join((__doc__ or "").split("\n\n")[1:]).strip()
    parser.epilog = (
        "Examples: `bywire verify` (the simulator's configuration, 200 campaigns); "
        "`bywire verify --config robot.toml --duration 600` (ten minutes on every core); "
        "`bywire verify --draw-robots 20 --budget 2000` (is any file the loader accepts"
        " unsafe? 20 drawn files, 100 campaigns each). "
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
        "--cluster",
        type=_cluster_address,
        metavar="ADDRESS",
        help=(
            "run the campaigns on a Dask distributed cluster: `local` starts one on 127.0.0.1"
            " (--jobs worker processes), tcp://HOST:PORT uses a scheduler you run (README)."
            " Needs pip install 'bywire[cluster]'"
        ),
    )
    parser.add_argument(
        "--hang-s",
        type=positive_seconds,
        default=None,
        metavar="S",
        help=(
            "real (wall-clock) seconds a campaign may run before it is killed with its worker"
            f" process and reported as a hang (default {HANG_S:g}, or --campaign-s if longer: a"
            " campaign simulated slower than real time is stuck); campaigns run in worker"
            " processes then, with --jobs 1 too. Not applied with --cluster"
        ),
    )
    parser.add_argument(
        "--workers-wait-s",
        type=positive_seconds,
        default=WORKERS_TIMEOUT_S,
        metavar="S",
        help=(
            "with --cluster: how long the cluster may be without a worker before verify gives"
            f" up (default {WORKERS_TIMEOUT_S:g}): at the start it is refused (exit 2); during"
            " the run, the run stops, and what ran is summarised and shrunk (exit 1)"
        ),
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
        help=(
            "accepted for old scripts, changes nothing: an unsafe combination of numbers is"
            " refused at load (exit 2)"
        ),
    )
    parser.add_argument(
        "--draw-robots",
        type=_positive_int,
        metavar="N",
        help=(
            "verify N robot files drawn across the loader's whole legal range instead: every"
            " key that picks no hardware moved to an end of its range, just inside an open end,"
            " the base file's value (--config, else the simulator's defaults) or between; a"
            " drawn file the loader refuses is repaired toward the base file. --budget is then"
            " shared: N files get BUDGET/N campaigns each (at least one). Each file and each"
            " failure's scenario is written to --out, with the keys that differ from the base"
        ),
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


@dataclass(slots=True)
class Tally:
    """What the campaigns did, added up."""

    campaigns: int = 0
    bridge_campaigns: int = 0
    bridge_checks: int = 0  # passes of the bridge campaigns, where B1..B3 are judged too
    simulated_s: float = 0.0
    events: int = 0
    checks: int = 0
    violations: Counter[str] = field(default_factory=Counter)
    transitions: set[str] = field(default_factory=set)
    failing: dict[str, Outcome] = field(default_factory=dict)  # the first campaign per invariant
    crashes: list[Crash] = field(default_factory=list)  # campaigns that killed a worker twice
    # A run problem, not a verdict: command frames the simulated computer never sent.
    hlc_refused: Counter[str] = field(default_factory=Counter)
    campaigns_refused: list[int] = field(default_factory=list)
    hangs: list[Hang] = field(default_factory=list)  # campaigns over --hang-s, killed

    def add(self, outcome: Result) -> None:
        if isinstance(outcome, Crash):
            self.crashes.append(outcome)
            return
        if isinstance(outcome, Hang):
            self.hangs.append(outcome)
            return
        self.campaigns += 1
        if outcome.hlc_refused:
            self.hlc_refused.update(outcome.hlc_refused)
            self.campaigns_refused.append(outcome.index)
        if outcome.bridge:
            self.bridge_campaigns += 1
            self.bridge_checks += outcome.checks
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


def hang_limit_s(asked_s: float | None, campaign_s: float) -> float:
    """The real time a campaign may run: as asked, else `HANG_S` or the campaign's simulated
    length if longer (it runs tens of times faster than real time; slower than real time, it is
    stuck). A fixed default reported a long campaign (--campaign-s 5000 at ~40x) as a hang."""
    return asked_s if asked_s is not None else max(HANG_S, campaign_s)


@dataclass(frozen=True, slots=True)
class Runner:
    """Where the campaigns run: `jobs` processes here, or the workers of a Dask cluster."""

    jobs: int
    client: Client | None = None
    cluster: str | None = None
    hang_s: float | None = None  # --hang-s: the real time a campaign may run here
    workers_wait_s: float = WORKERS_TIMEOUT_S  # --workers-wait-s: a cluster without a worker

    def outcomes(
        self,
        robot: RobotConfig,
        robot_text: str,
        job: CampaignJob,
        budget: int | None,
        until: float | None,
    ) -> Generator[Result, None, None]:
        if self.client is None:
            return campaign_outcomes(robot, job, self.jobs, budget, until, limit_s=self.hang_s)
        return cluster_outcomes(
            self.client,
            robot=robot,
            robot_file_hash=robot_hash(robot_text),
            job=job,
            budget=budget,
            until=until,
            no_worker_limit_s=self.workers_wait_s,
        )


@contextmanager
def _runner(args: argparse.Namespace) -> Iterator[Runner]:
    """`--jobs` processes, or `--cluster`'s workers (a local cluster shut down on the way out)."""
    if args.cluster is None:
        yield Runner(args.jobs, hang_s=hang_limit_s(args.hang_s, args.campaign_s))
        return
    with cluster_client(args.cluster, args.jobs, args.workers_wait_s) as client:
        yield Runner(worker_count(client), client, args.cluster, workers_wait_s=args.workers_wait_s)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C raises KeyboardInterrupt, so that it ends the run alike."""


@contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """While inside: SIGTERM interrupts the run as Ctrl-C does (`Terminated`). A forked worker
    inherits the handler and puts SIGTERM back to its default (`engine._work`). Off the main
    thread (verify called from a program's thread) the process's signals are left alone: only
    the main thread may set a handler."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminated(signum: int, frame: object) -> None:
        raise Terminated

    previous = signal.signal(signal.SIGTERM, terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def _held() -> Iterator[None]:
    """While inside, Ctrl-C and SIGTERM wait (blocked, in the main thread), and act as it ends:
    for bookkeeping that an interruption half-way would leave half done (a campaign counted
    without its violation, a file's entry not yet kept, a cluster half shut down)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTING)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _interruption(error: KeyboardInterrupt) -> str:
    return "SIGTERM" if isinstance(error, Terminated) else "Ctrl-C"


def _interrupted_status(interrupted: str | None) -> int | None:
    """The exit status of a run `interrupted` by Ctrl-C or SIGTERM: 128 + the signal."""
    if interrupted is None:
        return None
    return 128 + (signal.SIGTERM if interrupted == "SIGTERM" else signal.SIGINT)


def run(args: argparse.Namespace) -> int:
    """Ctrl-C or SIGTERM after the summary was printed (while the runner shuts down) keeps the
    status the summary gave; before it, the run's own handling summarises what ran."""
    status: list[int] = []
    with _sigterm_interrupts():
        try:
            return _run(args, status)
        except KeyboardInterrupt as interruption:
            if status:
                return status[0]
            return 128 + (signal.SIGTERM if isinstance(interruption, Terminated) else signal.SIGINT)


def _run(args: argparse.Namespace, status: list[int]) -> int:
    if args.draw_robots is not None:
        return run_drawn(args, status)
    robot = default_sim_config() if args.config is None else load_config(args.config)
    source = str(args.config) if args.config is not None else "the simulator's defaults"
    console = Console(stderr=True)
    show = sys.stderr.isatty() and not args.json
    budget = args.budget if args.budget is not None or args.duration else DEFAULT_BUDGET
    with ExitStack() as stack:
        runner = stack.enter_context(_runner(args))
        summary, _ = verify_robot(
            robot,
            source=source,
            config=args.config,
            out=args.out,
            args=args,
            budget=budget,
            console=console,
            show=show,
            runner=runner,
            robot_text=_robot_text(args.config),
        )
        if args.json:
            print(json.dumps(summary, indent=2), flush=True)
        else:
            _print_summary(Console(), summary, robot)
        interrupted = _interrupted_status(summary["interrupted"])
        status.append(
            interrupted
            if interrupted is not None
            else 1
            if _broken(summary) or summary["stopped"]
            else 0
        )
        with _held():  # a local cluster shuts down whole
            stack.close()
    return status[0]


def verify_robot(
    robot: RobotConfig,
    *,
    source: str,
    config: Path | None,
    out: Path,
    args: argparse.Namespace,
    budget: int | None,
    console: Console,
    show: bool,
    runner: Runner,
    robot_text: str,
) -> tuple[dict[str, Any], list[Reproduction]]:
    """`budget` campaigns of `args.seed` on `robot` (the file `robot_text`) (or campaigns until
    `args.duration` is up), on `runner`, every failure shrunk and written to `out`: the summary,
    and the shrunk failures."""
    until = None if args.duration is None else time.monotonic() + args.duration
    job = CampaignJob(args.seed, args.campaign_s)
    tally = Tally()
    stopped = None  # why the run ended before its budget, if it did (its outcomes are kept)
    interrupted = None  # "Ctrl-C" or "SIGTERM", if either ended it
    started = time.perf_counter()
    with _progress(console, show) as progress:
        task = progress.add_task("campaigns", total=budget, status="")
        outcomes = runner.outcomes(robot, robot_text, job, budget, until)
        try:
            for outcome in outcomes:
                with _held():  # counted whole, its violation with it
                    tally.add(outcome)
                status = ", ".join(f"{k} {n}" for k, n in sorted(tally.violations.items()))
                if tally.crashes:
                    status += f", {len(tally.crashes)} crashed a worker"
                if tally.hangs:
                    status += f", {len(tally.hangs)} hung"
                progress.update(task, advance=1, status=status or "0 violations")
        except ClusterLostError as lost:
            stopped = str(lost)
        except KeyboardInterrupt as interruption:
            interrupted = _interruption(interruption)
            stopped = f"interrupted by {interrupted}"
        finally:
            outcomes.close()  # its workers ended (or the cluster's campaigns cancelled) first
    wall_s = time.perf_counter() - started
    if interrupted is not None and tally.failing and show:
        console.print(
            f"interrupted by {interrupted}: shrinking the {len(tally.failing)} violations found"
            " so far (Ctrl-C again to skip)",
            highlight=False,
        )
    reproductions, unshrunk, again = _shrink_all(
        robot, tally, seed=args.seed, config=config, out=out, console=console, show=show
    )
    if again is not None and interrupted is None:  # the campaigns were done: only the shrinking
        interrupted, stopped = again, f"interrupted by {again} while shrinking"
    summary = _summary(
        source,
        args,
        tally,
        wall_s,
        reproductions,
        runner=runner,
        cannot_happen=_cannot_happen(robot),
    )
    summary["configuration"] = {"loss_distances": loss_rows(robot)}
    summary["stopped"] = stopped
    summary["interrupted"] = interrupted
    summary["unshrunk"] = unshrunk
    return summary, reproductions


def _shrink_all(
    robot: RobotConfig,
    tally: Tally,
    *,
    seed: int,
    config: Path | None,
    out: Path,
    console: Console,
    show: bool,
) -> tuple[list[Reproduction], list[dict[str, Any]], str | None]:
    """Shrink the first failing campaign of each broken invariant and write its scenario: the
    shrunk failures; those an interruption (Ctrl-C, SIGTERM) left unshrunk, each with its
    invariant and campaign; and that interruption, if any."""
    reproductions: list[Reproduction] = []
    if tally.failing:
        out.mkdir(parents=True, exist_ok=True)
    failing = sorted(tally.failing.items())
    try:
        for invariant, outcome in failing:
            reproductions.append(
                _shrunk(robot, invariant, outcome, seed=seed, config=config, out=out,
                        console=console, show=show)
            )  # fmt: skip
    except KeyboardInterrupt as interruption:
        left = failing[len(reproductions) :]
        unshrunk = [{"invariant": i, "seed": seed, "campaign": o.index} for i, o in left]
        return reproductions, unshrunk, _interruption(interruption)
    return reproductions, [], None


def _shrunk(
    robot: RobotConfig,
    invariant: str,
    outcome: Outcome,
    *,
    seed: int,
    config: Path | None,
    out: Path,
    console: Console,
    show: bool,
) -> Reproduction:
    """The failing campaign `outcome` shrunk for `invariant`, its scenario written to `out`."""
    name = f"verify-seed{seed}-campaign{outcome.index}-{invariant}"
    with _progress(console, show) as progress:
        task = progress.add_task(f"shrinking {invariant}", total=None, status="")

        def ran(runs: int, task: Any = task, progress: Progress = progress) -> None:
            progress.update(task, status=f"{runs} runs")

        found = shrink_failure(robot, outcome, invariant, name, on_run=ran)
    path = out / f"{name}.toml"
    replay = f"bywire sim --scenario {path}"
    if config is not None:
        replay += f" --config {config}"
    header = (
        f"Found by `bywire verify --seed {seed}` (campaign {outcome.index}),"
        f" shrunk from {found.original_steps} steps to {len(found.steps)}"
        f" in {found.shrink_runs} runs.\nReplay: {replay}\n"
        f"The expectation fails: {found.finding.invariant} of docs/SAFETY.md broke there."
    )
    with _held():  # written whole
        path.write_text(scenario_toml(found.scenario, header), encoding="utf-8")
    found.notes.append(str(path))
    return found


def _unshrunk_text(left: dict[str, Any]) -> str:
    """A violation an interruption left unshrunk, and how to find it again."""
    return (
        f"{left['invariant']} broken in campaign {left['campaign']} of seed {left['seed']}, not"
        f" shrunk (interrupted): --seed {left['seed']} --budget {left['campaign'] + 1} runs it"
        " again and shrinks it"
    )


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
    runner: Runner,
    cannot_happen: tuple[str, ...],
) -> dict[str, Any]:
    possible = [label for label in TRANSITIONS if label not in cannot_happen]
    never = [label for label in possible if label not in tally.transitions]
    return {
        "config": source,
        "seed": args.seed,
        "jobs": runner.jobs,
        "cluster": runner.cluster,
        "campaigns": tally.campaigns,
        "bridge_campaigns": tally.bridge_campaigns,
        "simulated_s": round(tally.simulated_s, 3),
        "wall_s": round(wall_s, 3),
        "campaigns_per_minute": round(tally.campaigns / wall_s * 60, 1) if wall_s else None,
        "speed_up": round(tally.simulated_s / wall_s, 1) if wall_s else None,
        "events_injected": tally.events,
        "invariant_checks": tally.checks * len(OUTPUT_INVARIANTS)
        + tally.bridge_checks * len(BRIDGE_INVARIANTS),
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
        # Campaigns that killed their worker twice (a crash of the process, not a violation).
        "crashes": [
            {"seed": c.seed, "index": c.index, "worker_deaths": c.deaths}
            for c in sorted(tally.crashes, key=_at)
        ],
        # Run problems: the campaigns tested less than they drew (no verdict changes with them).
        "hlc_refused": {
            "frames": dict(sorted(tally.hlc_refused.items())),
            "campaigns": sorted(tally.campaigns_refused),
        },
        # Campaigns still running after --hang-s of real time, killed with their worker.
        "hangs": [
            {"seed": h.seed, "index": h.index, "limit_s": h.limit_s}
            for h in sorted(tally.hangs, key=_at)
        ],
        "failures": [
            {
                "invariant": r.finding.invariant,
                "time_s": r.finding.time_s,
                "detail": r.finding.detail,
                "steps": len(r.steps),
                "shrunk_from": r.original_steps,
                "scenario": r.notes[0] if r.notes else None,
                "fails_on_replay": r.fails_on_replay,
            }
            for r in reproductions
        ],
    }


NO_REPLAY = (
    "but its scenario passes when replayed (bywire sim --scenario): the finding stands, its"
    " reproduction does not; a bug of bywire verify's, please report it with the seed"
)


def _at(finding: Crash | Hang) -> int:
    return finding.index


def _broken(summary: dict[str, Any]) -> bool:
    """A violation, or a campaign that crashed or hung its worker."""
    return bool(any(summary["violations"].values()) or summary["crashes"] or summary["hangs"])


def _times(deaths: int | None) -> str:
    return "repeatedly" if deaths is None else "twice" if deaths == 2 else f"{deaths} times"


def _where(summary: dict[str, Any]) -> str:
    if summary["cluster"] is None:
        return f"{summary['jobs']} processes"
    return f"{summary['jobs']} workers of the cluster {summary['cluster']}"


def _print_summary(console: Console, summary: dict[str, Any], robot: RobotConfig) -> None:
    violations = summary["violations"]
    transitions = summary["transitions"]
    console.print(f"[bold]bywire verify[/bold] on {summary['config']} (seed {summary['seed']})")
    console.print("  configuration: what each timeout buys (at top speed, before the stop):")
    for loss in loss_distances(robot):
        console.print(f"    {loss}", highlight=False)
    console.print(
        f"  {summary['campaigns']} campaigns ({summary['bridge_campaigns']} with the ROS 2"
        f" bridge as the computer), {summary['simulated_s']:.0f} s simulated in"
        f" {summary['wall_s']:.1f} s on {_where(summary)}"
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
    refused = summary["hlc_refused"]
    if refused["frames"]:
        frames = ", ".join(f"{name} {n}" for name, n in refused["frames"].items())
        console.print(
            f"[yellow]  run problem: the simulated computer never sent"
            f" {sum(refused['frames'].values())} command frames ({frames}) in"
            f" {len(refused['campaigns'])} campaigns[/yellow] (its transmit mailboxes full, its"
            " port bus-off, or nothing to sign with): those periods tested less than drawn",
            highlight=False,
        )
    for failure in summary["failures"]:
        console.print(
            f"[red]  {failure['invariant']} broken at {failure['time_s']:.3f} s:"
            f" {failure['detail']}[/red]; shrunk from {failure['shrunk_from']} steps to"
            f" {failure['steps']}: {failure['scenario']}",
            highlight=False,
        )
        if failure["fails_on_replay"] is False:
            console.print(f"[red]    {NO_REPLAY}[/red]", highlight=False)
    for left in summary["unshrunk"]:
        console.print(f"[red]  {_unshrunk_text(left)}[/red]", highlight=False)
    for crash in summary["crashes"]:
        console.print(
            f"[red]  campaign {crash['index']} of seed {crash['seed']} killed its worker"
            f" {_times(crash['worker_deaths'])}[/red] (a crash of the process: a finding of its"
            f" own; replay it alone: bywire verify --seed {crash['seed']} ... --jobs 1)",
            highlight=False,
        )
    for hang in summary["hangs"]:
        console.print(
            f"[red]  campaign {hang['index']} of seed {hang['seed']} still ran after"
            f" {hang['limit_s']:g} s of real time[/red] (a hang: killed with its worker, a finding"
            f" of its own; replay it alone: bywire verify --seed {hang['seed']} ... --jobs 1)",
            highlight=False,
        )
    if summary["stopped"]:
        console.print(
            f"[yellow]  stopped after {summary['campaigns']} campaigns:"
            f" {summary['stopped']}[/yellow]",
            highlight=False,
        )
    broken = _broken(summary)
    verdict = "[red]VIOLATIONS[/red]" if broken else "[green]clean[/green]"
    if summary["stopped"]:
        verdict = f"[yellow]incomplete[/yellow], {verdict} so far"
    console.print(f"  result: {verdict}")


# --- drawn robot files --------------------------------------------------------------------------


def run_drawn(args: argparse.Namespace, status: list[int]) -> int:
    """`--draw-robots N`: N files drawn across the loader's legal space, each verified; exit 1
    if any file had a violation, 130 on Ctrl-C and 143 on SIGTERM (the files done so far are
    summarised, the interrupted one with the campaigns it ran)."""
    if args.duration is not None:
        print("bywire verify: error: --draw-robots takes --budget, not --duration", file=sys.stderr)
        return 2
    base_text, base_name = _base_text(args.config)
    schema = Schema.of(base_text, base_name)
    count = args.draw_robots
    budget = args.budget if args.budget is not None else DEFAULT_BUDGET
    each = max(1, budget // count)
    console = Console(stderr=True)
    show = sys.stderr.isatty() and not args.json
    args.out.mkdir(parents=True, exist_ok=True)
    files: list[dict[str, Any]] = []
    refusals: Counter[str] = Counter()
    refused = 0
    started = time.perf_counter()
    interrupted: str | None = None
    stopped = None
    with ExitStack() as stack:
        runner = stack.enter_context(_runner(args))
        try:
            for drawn in draw_robots(schema, args.seed, count):
                refusals.update(drawn.refusals)
                refused += bool(drawn.refusals)
                entry = _verify_drawn(
                    drawn, schema, base_name, each, args, files=files,
                    runner=runner, console=console, show=show,
                )  # fmt: skip
                if entry["interrupted"]:  # what ran of the file is in its entry
                    interrupted = entry["interrupted"]
                    break
                if entry["stopped"]:  # the cluster is gone: no later file can run either
                    stopped = entry["stopped"]
                    break
        except KeyboardInterrupt as interruption:  # one between the files
            interrupted = _interruption(interruption)
        result = _drawn_result(
            args, schema, base_name, files, each=each, runner=runner, refused=refused,
            refusals=refusals, interrupted=interrupted, stopped=stopped, started=started,
        )  # fmt: skip
        if args.json:
            print(json.dumps(result, indent=2), flush=True)
        else:
            _print_drawn(Console(soft_wrap=True), result)
        interrupted_status = _interrupted_status(interrupted)
        status.append(
            interrupted_status
            if interrupted_status is not None
            else 1
            if result["violating_files"] or stopped
            else 0
        )
        with _held():  # a local cluster shuts down whole
            stack.close()
    return status[0]


def _drawn_result(
    args: argparse.Namespace,
    schema: Schema,
    base_name: str,
    files: list[dict[str, Any]],
    *,
    each: int,
    runner: Runner,
    refused: int,
    refusals: Counter[str],
    interrupted: str | None,
    stopped: str | None,
    started: float,
) -> dict[str, Any]:
    count = args.draw_robots
    return {
        "draw_robots": count,
        "base": base_name,
        "seed": args.seed,
        "jobs": runner.jobs,
        "cluster": runner.cluster,
        "campaigns_per_file": each,
        "keys_drawn": len(schema.keys),
        "keys_kept": _kept(schema),
        "files_verified": len(files),
        "interrupted": interrupted,
        "stopped": stopped,
        "wall_s": round(time.perf_counter() - started, 3),
        "campaigns": sum(f["campaigns"] for f in files),
        "files_refused": refused,
        "refusals_repaired": dict(refusals.most_common()),
        "violating_files": [f["file"] for f in files if _broken(f)],
        "files": files,
    }


def _verify_drawn(
    drawn: DrawnRobot,
    schema: Schema,
    base_name: str,
    each: int,
    args: argparse.Namespace,
    *,
    files: list[dict[str, Any]],
    runner: Runner,
    console: Console,
    show: bool,
) -> dict[str, Any]:
    """One drawn file written to --out and verified on `runner`: its entry of the summary, kept
    in `files` as soon as its campaigns are done (an interruption after them keeps it: the keys
    each failure needs are then left unsearched, None)."""
    path = args.out / f"robot-{drawn.index:02d}.toml"
    text = _drawn_text(drawn, args.seed, base_name)
    path.write_text(text, encoding="utf-8")
    if show:
        console.print(
            f"[{drawn.index}/{args.draw_robots}] {path}: {len(drawn.changed)} keys drawn,"
            f" {len(drawn.repairs)} put back",
            highlight=False,
        )
    out = args.out / f"robot-{drawn.index:02d}-failures"
    summary, found = verify_robot(
        drawn.robot,
        source=str(path),
        config=path,
        out=out,
        args=args,
        budget=each,
        console=console,
        show=show,
        runner=runner,
        robot_text=text,
    )
    with _held():
        entry = _file_entry(drawn, path, summary)
        for failure in entry["failures"]:
            failure.update(keys_needed=None, robot=None)
        files.append(entry)
    try:
        for failure, reproduction in zip(entry["failures"], found, strict=True):
            failure.update(
                _keys_needed(schema, drawn, reproduction, out, console=console, show=show)
            )
    except KeyboardInterrupt as interruption:
        entry["interrupted"] = entry["interrupted"] or _interruption(interruption)
    if show:
        violating = sum(summary["violations"].values())
        console.print(
            f"  {summary['campaigns']} campaigns: "
            + (f"[red]{violating} violating[/red]" if violating else "[green]clean[/green]"),
            highlight=False,
        )
    return entry


def _robot_text(config: Path | None) -> str:
    """The robot file's text (--config, else the packaged simulator defaults), for its hash."""
    if config is not None:
        return read_text(config, "configuration file")
    resource = resources.files("bywire")
    for part in DEFAULT_SIM_RESOURCE:
        resource = resource.joinpath(part)
    return resource.read_text(encoding="utf-8")


def _base_text(config: Path | None) -> tuple[str, str]:
    """The base file's text and name: --config, else the packaged simulator defaults."""
    if config is not None:
        load_config(config)  # refused with its reason (exit 2) before anything is drawn
        return _robot_text(config), str(config)
    return _robot_text(None), "bywire/defaults/sim.toml"


def _kept(schema: Schema) -> list[str]:
    return [".".join(read.parts) for read in schema.kept]


def _drawn_text(drawn: DrawnRobot, seed: int, base: str) -> str:
    """The drawn file with a header: where it came from and what differs from its base."""
    lines = [
        f"Drawn by `bywire verify --draw-robots --seed {seed}`: file {drawn.index}, from {base}.",
        f"{len(drawn.changed)} keys differ from the base file:",
        *(
            f"  {key} = {_show(new)} (base {_show(old)})"
            for key, (old, new) in drawn.changed.items()
        ),
    ]
    if drawn.repairs:
        lines.append(f"{len(drawn.repairs)} drawn values put back to the base file's (refused):")
        lines += [f"  {r.key} = {_show(r.drawn)}: {r.rule}" for r in drawn.repairs]
    header = "\n".join(f"# {line}" for line in lines)
    return f"{header}\n\n{drawn.text}"


def _show(value: object) -> str:
    return toml_value(list(value) if isinstance(value, tuple) else value)


def _file_entry(drawn: DrawnRobot, path: Path, summary: dict[str, Any]) -> dict[str, Any]:
    return {
        "file": str(path),
        "index": drawn.index,
        "campaigns": summary["campaigns"],
        "violations": {k: n for k, n in summary["violations"].items() if n},
        "failures": summary["failures"],
        "crashes": summary["crashes"],
        "hangs": summary["hangs"],
        "stopped": summary["stopped"],
        "interrupted": summary["interrupted"],
        "unshrunk": summary["unshrunk"],
        "changed": {key: [_plain(old), _plain(new)] for key, (old, new) in drawn.changed.items()},
        "repaired": [
            {"key": r.key, "drawn": _plain(r.drawn), "base": _plain(r.base), "rule": r.rule}
            for r in drawn.repairs
        ],
    }


def _keys_needed(
    schema: Schema,
    drawn: DrawnRobot,
    reproduction: Reproduction,
    out: Path,
    *,
    console: Console,
    show: bool,
) -> dict[str, Any]:
    """Which of the file's drawn keys the shrunk failure needs, and the base file with only
    those drawn, written beside the scenario (the scenario replays on it)."""
    invariant = reproduction.finding.invariant

    def fails(robot: RobotConfig) -> bool:
        """The written scenario, as `bywire sim --scenario` replays it, breaks the invariant
        again on `robot` (the oracle watching)."""
        result = Campaign(robot).run_scenario(reproduction.scenario)
        return any(v.invariant == invariant for v in result.oracle.violations)

    if show:
        console.print(f"  finding the keys {invariant} needs ...", highlight=False)
    changed = {key: new for key, (_old, new) in drawn.changed.items()}
    needed = keys_needed(schema, changed, fails)
    minimal = robot_with(schema, needed)
    assert minimal is not None  # every key put back kept the file loading
    scenario = Path(reproduction.notes[0])
    path = out / f"{scenario.stem}-robot.toml"
    lines = [
        f"The base file ({drawn.index} of `bywire verify --draw-robots`) with only the drawn"
        f" keys {invariant} needs: put any one back and it no longer fails.",
        f"Replay: bywire sim --scenario {scenario} --config {path}",
    ]
    header = "\n".join(f"# {line}" for line in lines)
    path.write_text(f"{header}\n\n{minimal[0]}", encoding="utf-8")
    return {
        "keys_needed": {key: _plain(value) for key, value in needed.items()},
        "robot": str(path),
        "replays": fails(minimal[1]),
    }


def _plain(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value


def _print_drawn(console: Console, result: dict[str, Any]) -> None:
    console.print(
        f"[bold]bywire verify --draw-robots {result['draw_robots']}[/bold] from"
        f" {result['base']} (seed {result['seed']})",
        highlight=False,
    )
    console.print(
        f"  {result['keys_drawn']} keys drawn across their legal range;"
        f" {len(result['keys_kept'])} hardware picks kept as the base file has them",
        highlight=False,
    )
    console.print(
        f"  {result['files_verified']} files, {result['campaigns']} campaigns"
        f" ({result['campaigns_per_file']} a file), {result['wall_s']:.1f} s",
        highlight=False,
    )
    refusals = result["refusals_repaired"]
    if refusals:
        console.print(
            f"  {result['files_refused']} of {result['files_verified']} drawn files were refused"
            " at first and repaired toward the base file; files refused by each rule:",
            highlight=False,
        )
        for rule, count in refusals.items():
            console.print(f"    {count:4d}  {escape(rule)}", highlight=False, soft_wrap=True)
    for entry in result["files"]:
        partly = (
            f", interrupted after {entry['campaigns']} campaigns" if entry["interrupted"] else ""
        )
        if not _broken(entry):
            console.print(
                f"  {entry['file']}: clean ({len(entry['changed'])} keys drawn{partly})",
                highlight=False,
            )
            continue
        broken = ", ".join(f"{k} {n}" for k, n in entry["violations"].items())
        console.print(f"[red]  {entry['file']}: {broken}[/red]", highlight=False)
        for crash in entry["crashes"]:
            console.print(
                f"[red]    campaign {crash['index']} of seed {crash['seed']} killed its worker"
                f" {_times(crash['worker_deaths'])}[/red]",
                highlight=False,
            )
        for hang in entry["hangs"]:
            console.print(
                f"[red]    campaign {hang['index']} of seed {hang['seed']} still ran after"
                f" {hang['limit_s']:g} s of real time[/red]",
                highlight=False,
            )
        for failure in entry["failures"]:
            console.print(
                f"    {failure['invariant']} at {failure['time_s']:.3f} s:"
                f" {escape(failure['detail'])}; {failure['scenario']}",
                highlight=False,
            )
            if failure["fails_on_replay"] is False:
                console.print(f"[red]      {NO_REPLAY}[/red]", highlight=False)
            if failure["keys_needed"] is None:
                console.print("      keys it needs: not searched (interrupted)", highlight=False)
                continue
            needed = ", ".join(f"{k} = {_show(v)}" for k, v in failure["keys_needed"].items())
            console.print(
                f"      keys it needs: {escape(needed) or 'none (the base file fails too)'};"
                f" {failure['robot']}",
                highlight=False,
            )
        for left in entry["unshrunk"]:
            console.print(
                f"[red]    {_unshrunk_text(left)} (with --config {entry['file']})[/red]",
                highlight=False,
            )
        changed = ", ".join(
            f"{key} = {_show(new)}" for key, (_old, new) in entry["changed"].items()
        )
        console.print(f"    keys differing from the base: {escape(changed)}", highlight=False)
    verdict = "[red]VIOLATIONS[/red]" if result["violating_files"] else "[green]clean[/green]"
    if result["interrupted"]:
        verdict = (
            f"[yellow]interrupted by {result['interrupted']}[/yellow]"
            f" after {result['files_verified']} files, {verdict}"
        )
    if result["stopped"]:
        console.print(f"[yellow]  stopped: {escape(result['stopped'])}[/yellow]", highlight=False)
        verdict = f"[yellow]incomplete[/yellow] after {result['files_verified']} files, {verdict}"
    console.print(f"  result: {verdict}")
