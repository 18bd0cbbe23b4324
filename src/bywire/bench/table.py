"""The benchmark's figures as a rich table: value, target, whether it is met, and a note."""

from __future__ import annotations

from rich import box
from rich.table import Table

from bywire.bench.figures import BenchResult, Figure, all_figures
from bywire.bench.tail import PARTS, PhaseTail

_VERDICTS = {True: "[green]met[/]", False: "[bold red]MISSED[/]", None: ""}


def format_value(figure: Figure) -> str:
    """The value with its unit, at a precision that suits the unit."""
    value = figure.value
    if value is None:
        return "n/a"
    formats = {"ms": "{:.3f} ms", "%": "{:.1f} %", "MB": "{:.1f} MB", "x": "{:.1f}x"}
    return formats.get(figure.unit, "{:.0f}").format(value)


def machine_line(machine: dict[str, object]) -> str:
    """One line about where the figures were taken."""
    return (
        f"{machine.get('cpu_model')}, {machine.get('usable_cpus')} usable CPUs,"
        f" Python {machine.get('python')}, bywire {machine.get('build')} build,"
        f" {machine.get('date_utc')}"
    )


PHASE_NOTES = {
    "feed": ", telemetry feed on, a Foxglove client attached",
    "dashboard": ", telemetry feed on, bywire dashboard attached (child process)",
    "secoc_flood": ", every command authenticated (SecOC)",
}


def section_title(result: BenchResult, section: str) -> str:
    """What a section of the table measured under."""
    for phase in result.realtime.phases:
        if phase.name == section:
            load = "nominal load" if phase.flood_load is None else "CAN bus flooded"
            return f"{load}{PHASE_NOTES.get(phase.name, '')}, {phase.duration_s:g} s"
    if section == "secoc":
        return "authenticated commands (SecOC), per command"
    return "whole process"


def render(result: BenchResult) -> Table:
    """The table; sections separate the nominal phase, the flood phase and the rest."""
    table = Table(
        title="bywire bench: simulated robot in real time (REQUIREMENTS §8)",
        caption=machine_line(result.machine),
        box=box.SIMPLE_HEAD,
    )
    for column in ("figure", "value", "target", "result", "note"):
        table.add_column(column, justify="right" if column == "value" else "left")
    section = None
    for figure in all_figures(result):
        if figure.section != section:
            if section is not None:
                table.add_section()
            section = figure.section
            table.add_row(f"[bold]{section_title(result, section)}[/]")
        table.add_row(
            figure.label, format_value(figure), figure.target, _VERDICTS[figure.met], figure.note
        )
    return table


def summary_line(result: BenchResult) -> str:
    """Which targets were missed, or that every one was met."""
    missed = [figure.label for figure in all_figures(result) if figure.met is False]
    if not missed:
        return "Every target of REQUIREMENTS §8 measured here was met."
    return "Targets missed: " + "; ".join(missed) + "."


def render_tail(tails: tuple[PhaseTail, ...]) -> Table:
    """`--probe`: per phase and path, the late intervals' time by cause; the collections."""
    table = Table(
        title="where the tail comes from (intervals over 0.5 ms, time summed by cause)",
        box=box.SIMPLE_HEAD,
    )
    table.add_column("phase / path")
    table.add_column("late", justify="right")
    for part in PARTS:
        table.add_column(part, justify="right")
    table.add_column("worst, by cause")
    for phase in tails:
        for tail in phase.tails:
            worst = ""
            if tail.worst:
                length_s, _start_s, parts = tail.worst[0]
                main = sorted(parts.items(), key=lambda item: item[1], reverse=True)[:2]
                shares = ", ".join(f"{name} {seconds * 1e3:.2f}" for name, seconds in main)
                worst = f"{length_s * 1e3:.2f} ms: {shares}"
            table.add_row(
                f"{phase.name} {tail.path}",
                f"{tail.late}/{tail.samples}",
                *(f"{tail.parts_s[part] * 1e3:.2f}" for part in PARTS),
                worst,
            )
        collections = "; ".join(
            f"gen{gc.generation}: {gc.count}, max {gc.max_s * 1e3:.2f} ms" for gc in phase.gc
        )
        table.add_row(f"{phase.name} gc", "", *([""] * len(PARTS)), collections)
        table.add_section()
    return table
