"""What a finished simulated run amounts to: a typed summary, its text tables and its JSON form."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from bywire.canlog.write import BusTally
from bywire.error_flags import flag_names
from bywire.runtime.schedule import PeriodicTask
from bywire.sim.runner import SimRun, Verdict
from bywire.sim.scenario import FAULTS, Scenario

STOP_LABEL = "STOP"


@dataclass(frozen=True, slots=True)
class ModeChange:
    at_s: float
    mode: str


@dataclass(frozen=True, slots=True)
class LabelledEvent:
    """A labelled scenario event and how long the outputs took to be safe after it."""

    label: str
    at_s: float
    action: str  # the fault's name, or rc / hlc / hlc_lights / hlc_control
    already_safe: bool  # safe just before it: no time to safe outputs to measure
    time_to_safe_s: float | None  # until next safe (within 2 s); None: already or never safe
    deadline_s: float | None  # the tightest `within_s` of expectations after it


@dataclass(frozen=True, slots=True)
class ExpectationResult:
    description: str
    status: str  # "pass", "fail", or "not reached" (after the end of a run cut short)
    measured_s: float | None
    deadline_s: float | None


@dataclass(frozen=True, slots=True)
class InputStats:
    ibus_frames: int
    ibus_checksum_errors: int
    ibus_resyncs: int
    can_rejected: dict[str, int]
    reports_sent: int
    bus_frames: int | None
    bus_frames_by_sender: dict[str, int]
    hlc_refused: dict[str, int]  # the simulated computer's frames its port refused, by message


@dataclass(frozen=True, slots=True)
class TaskRow:
    name: str
    nominal_rate_hz: float
    rate_hz: float
    runs: int
    runtime_share_pct: float
    jitter_p99_s: float
    jitter_max_s: float
    overruns: int
    budget_exceeded: int


@dataclass(frozen=True, slots=True)
class Summary:
    """Everything `bywire sim` reports about one run; times are from the start of the run."""

    scenario: str
    description: str
    simulated_s: float
    wall_s: float
    speedup: float
    distance_m: float
    top_speed_mps: float
    mode_changes: tuple[ModeChange, ...]
    events: tuple[LabelledEvent, ...]
    expectations: tuple[ExpectationResult, ...]
    error_flags_seen: tuple[str, ...]  # after power-up: the faults of the run
    power_up_flags: tuple[str, ...]  # before the first arming (no frame yet, not armed)
    inputs: InputStats
    tasks: tuple[TaskRow, ...]

    @property
    def stop_times(self) -> list[LabelledEvent]:
        """The event labelled STOP if there is one, else every fault the robot went safe after."""
        chosen = [e for e in self.events if e.label.upper() == STOP_LABEL]
        return chosen or [e for e in self.events if e.action in FAULTS and e.time_to_safe_s]

    @property
    def failed(self) -> list[str]:
        return [e.description for e in self.expectations if e.status == "fail"]

    @property
    def passed(self) -> bool:
        return not self.failed

    def as_json(self) -> dict[str, Any]:
        """A dict for json.dumps: stable keys, numbers as numbers, None as null."""
        stop_times = [asdict(event) for event in self.stop_times]
        return {
            **asdict(self),
            "stop_times": stop_times,
            "passed": self.passed,
            "failed": self.failed,
        }


# --- building -----------------------------------------------------------------------------------


def build_summary(run: SimRun, wall_s: float, bus: BusTally | None = None) -> Summary:
    """The summary of `run` after `run.run()` returned; `wall_s` is how long it took."""
    start_s = run.started_at
    simulated_s = min(run.world.clock.now() - start_s, run.duration_s)
    last = run.record.samples.last
    return Summary(
        scenario=run.scenario.name,
        description=run.scenario.description,
        simulated_s=simulated_s,
        wall_s=wall_s,
        speedup=simulated_s / wall_s if wall_s > 0 else 0.0,
        distance_m=0.0 if last is None else last.distance_m,
        top_speed_mps=run.record.top_speed_mps,
        mode_changes=tuple(ModeChange(at - start_s, m.name) for at, m in run.runtime.mode_log),
        events=_labelled_events(run),
        expectations=tuple(_result(v, run, simulated_s) for v in run.record.verdicts),
        error_flags_seen=tuple(flag_names(run.record.error_flags_seen)),
        power_up_flags=tuple(flag_names(run.record.power_up_flags)),
        inputs=_inputs(run, bus),
        tasks=tuple(task_row(task, simulated_s, wall_s) for task in run.runtime.tasks),
    )


def _labelled_events(run: SimRun) -> tuple[LabelledEvent, ...]:
    rows = []
    for timing in run.record.fault_timings:
        rows.append(
            LabelledEvent(
                label=timing.label,
                at_s=timing.at_s - run.started_at,
                action=str(timing.event.values.get("fault", timing.event.kind)),
                already_safe=timing.already_safe,
                time_to_safe_s=None if timing.already_safe else timing.time_to_safe_s,
                deadline_s=_deadline_s(run.scenario, timing.label),
            )
        )
    return tuple(rows)


def _deadline_s(scenario: Scenario, label: str) -> float | None:
    windows = [e.within_s for e in scenario.expectations if e.after == label and e.within_s]
    return min(windows, default=None)


def _decided_at_s(verdict: Verdict, scenario: Scenario) -> float:
    """When (from the start) an expectation is decided at the latest."""
    expectation = verdict.expectation
    if expectation.at_s is not None:
        return expectation.at_s
    starts = [e.at_s for e in scenario.events if e.label == expectation.after]
    return min(starts, default=0.0) + (expectation.within_s or expectation.during_s or 0.0)


def _result(verdict: Verdict, run: SimRun, simulated_s: float) -> ExpectationResult:
    expectation = verdict.expectation
    cut_short = simulated_s < run.scenario.duration_s  # by --duration, or by Ctrl-C
    if verdict.passed:
        status = "pass"
    elif cut_short and _decided_at_s(verdict, run.scenario) >= simulated_s:
        status = "not reached"
    else:
        status = "fail"
    return ExpectationResult(
        expectation.describe(), status, verdict.measured_s, expectation.within_s
    )


def _inputs(run: SimRun, bus: BusTally | None) -> InputStats:
    runtime = run.runtime
    parser = runtime.ibus.parser.stats
    by_sender = dict(sorted(bus.frames_by_sender.items())) if bus else {}
    return InputStats(
        ibus_frames=parser.frames,
        ibus_checksum_errors=parser.checksum_errors,
        ibus_resyncs=parser.resyncs,
        can_rejected={
            reason.value: n for reason, n in sorted(runtime.can.rejected.items(), key=str)
        }
        | {  # authenticated commands: verification failures, by reason
            failure.value: n for failure, n in sorted(runtime.can.auth_failures.items(), key=str)
        },
        reports_sent=runtime.reports_sent,
        bus_frames=sum(by_sender.values()) if bus else None,
        bus_frames_by_sender=by_sender,
        hlc_refused=dict(sorted(run.world.hlc.refused.items())),
    )


def task_row(task: PeriodicTask, simulated_s: float, wall_s: float) -> TaskRow:
    stats = task.stats
    return TaskRow(
        name=task.spec.name,
        nominal_rate_hz=task.spec.rate_hz,
        rate_hz=stats.runs / simulated_s if simulated_s > 0 else 0.0,
        runs=stats.runs,
        runtime_share_pct=100.0 * stats.spent_s / wall_s if wall_s > 0 else 0.0,
        # The percentile is a 10 µs bin's upper edge: never report it above the maximum.
        jitter_p99_s=stats.jitter_percentile_s(0.99),
        jitter_max_s=stats.max_jitter_s,
        overruns=stats.overruns,
        budget_exceeded=stats.budget_exceeded,
    )


# --- text ---------------------------------------------------------------------------------------


def _ms(seconds: float | None, digits: int = 1) -> str:
    return "—" if seconds is None else f"{seconds * 1000:.{digits}f} ms"


def _safe_text(event: LabelledEvent) -> str:
    if event.already_safe:
        return "already safe"
    return "not safe" if event.time_to_safe_s is None else _ms(event.time_to_safe_s)


def _stop_text(stop: LabelledEvent) -> str:
    took = _safe_text(stop)
    where = f"after '{escape(stop.label)}' at {stop.at_s:.3f} s"
    if stop.deadline_s is None:
        return f"{took} {where}"
    met = stop.time_to_safe_s is not None and stop.time_to_safe_s <= stop.deadline_s
    verdict = "[green]within[/]" if met else "[red]OVER[/]"
    return f"{took} {where}, {verdict} {_ms(stop.deadline_s)}"


def _table(title: str, *columns: str) -> Table:
    table = Table(title=title, title_justify="left", title_style="bold", box=None, pad_edge=False)
    for index, column in enumerate(columns):
        table.add_column(column, justify="left" if index == 0 else "right")
    return table


def _events_table(summary: Summary) -> Table:
    table = _table("Labelled events", "event", "at", "action", "next safe after")
    for e in summary.events:
        table.add_row(escape(e.label), f"{e.at_s:.3f} s", e.action, _safe_text(e))
    return table


def _expectations_table(summary: Summary) -> Table:
    table = _table("Expectations", "result", "expectation", "measured", "deadline")
    table.columns[1].justify = "left"
    style = {"pass": "[green]PASS[/]", "fail": "[red]FAIL[/]", "not reached": "[yellow]—[/]"}
    for e in summary.expectations:
        measured = _ms(e.measured_s) if e.measured_s is not None else ""
        deadline = _ms(e.deadline_s) if e.deadline_s is not None else ""
        table.add_row(style[e.status], escape(e.description), measured, deadline)
    return table


def _task_table(summary: Summary) -> Table:
    table = _table(
        "Tasks", "task", "rate", "runs", "runtime", "jitter p99", "jitter max", "overruns"
    )
    for t in summary.tasks:
        table.add_row(
            t.name,
            f"{t.rate_hz:.1f} Hz",
            str(t.runs),
            f"{t.runtime_share_pct:.2f} %",
            _ms(t.jitter_p99_s, 3),
            _ms(t.jitter_max_s, 3),
            str(t.overruns),
        )
    return table


def _input_lines(inputs: InputStats) -> list[str]:
    rejected = ", ".join(f"{n} {reason}" for reason, n in inputs.can_rejected.items()) or "none"
    lines = [
        f"IBUS: {inputs.ibus_frames} frames, {inputs.ibus_checksum_errors} checksum errors,"
        f" {inputs.ibus_resyncs} resyncs",
        f"CAN commands rejected: {rejected}; reports sent: {inputs.reports_sent}",
    ]
    if inputs.bus_frames is not None:
        senders = ", ".join(f"{name} {n}" for name, n in inputs.bus_frames_by_sender.items())
        lines.append(f"CAN bus: {inputs.bus_frames} frames ({senders})")
    if inputs.hlc_refused:
        refused = ", ".join(f"{name} {n}" for name, n in inputs.hlc_refused.items())
        lines.append(
            f"[yellow]Simulated computer: {sum(inputs.hlc_refused.values())} command frames"
            f" never sent ({refused}): its transmit mailboxes full, its port bus-off, or"
            " nothing to sign with[/]"
        )
    return lines


def render(summary: Summary, console: Console) -> None:
    """Print the summary as text tables (colour only when the console is a terminal)."""
    say = console.print
    say(
        f"[bold]Scenario {escape(summary.scenario)}[/]: {escape(summary.description)}",
        soft_wrap=True,
    )
    say(
        f"Simulated {summary.simulated_s:.1f} s in {summary.wall_s:.2f} s wall time"
        f" ({summary.speedup:.1f}× real time)"
    )
    say(f"Distance {summary.distance_m:.2f} m, top speed {summary.top_speed_mps:.2f} m/s")
    modes = " → ".join(f"{c.mode} ({c.at_s:.3f} s)" for c in summary.mode_changes)
    say(f"Modes: {modes}", soft_wrap=True)
    for stop in summary.stop_times:
        say(f"Time to STOP: {_stop_text(stop)}", soft_wrap=True)
    say(f"Error flags seen: {', '.join(summary.error_flags_seen) or 'none'}", soft_wrap=True)
    if summary.power_up_flags:
        say(
            f"  before the first arming (power-up): {', '.join(summary.power_up_flags)}",
            soft_wrap=True,
        )
    for line in _input_lines(summary.inputs):
        say(line, soft_wrap=True)
    for table in (_events_table(summary), _expectations_table(summary), _task_table(summary)):
        say()
        say(table)
    total = len(summary.expectations)
    passed = sum(e.status == "pass" for e in summary.expectations)
    unreached = sum(e.status == "not reached" for e in summary.expectations)
    note = f", {unreached} not reached (the run ended before them)" if unreached else ""
    colour = "green" if summary.passed else "red"
    say(f"\n[bold {colour}]{passed} of {total} expectations passed{note}[/]")
    for description in summary.failed:
        say(f"[red]FAILED:[/] {escape(description)}", soft_wrap=True)
