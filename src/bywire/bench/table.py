"""The benchmark's figures as a rich table: value, target, whether it is met, and a note."""

from __future__ import annotations

from rich import box
from rich.table import Table

from bywire.bench.figures import BenchResult, Figure, all_figures

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
        f" Python {machine.get('python')}, {machine.get('date_utc')}"
    )


def section_title(result: BenchResult, section: str) -> str:
    """What a section of the table measured under."""
    for phase in result.realtime.phases:
        if phase.name == section:
            load = "nominal load" if phase.flood_load is None else "CAN bus flooded"
            return f"{load}, {phase.duration_s:g} s"
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
