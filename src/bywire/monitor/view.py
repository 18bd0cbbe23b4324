"""How a monitor row looks: cells as rich Text (errors in bold red), and a snapshot table."""

from __future__ import annotations

from rich.table import Table
from rich.text import Text

from bywire.monitor.bus_state import MessageRow

COLUMNS = ("id", "name", "count", "rate Hz", "age s", "data", "errors", "signals")
ERROR_STYLE = "bold red"
STALE_AGE_S = 1.0  # a 50 Hz message this old has stopped: its age is shown dimmed


def cells(row: MessageRow) -> tuple[Text, ...]:
    """The row's cells, in ``COLUMNS`` order."""
    return (
        Text(f"0x{row.arbitration_id:03X}"),
        Text(row.name or "(unknown)", style="" if row.name else "italic yellow"),
        Text(str(row.count), justify="right"),
        Text(f"{row.rate_hz:.1f}", justify="right"),
        Text(f"{row.age_s:.2f}", justify="right", style="dim" if row.age_s > STALE_AGE_S else ""),
        Text(row.data.hex(" ").upper()),
        _errors(row),
        Text("  ".join(str(signal) for signal in row.signals)),
    )


def _errors(row: MessageRow) -> Text:
    counts = [
        (row.crc_errors, "crc"),
        (row.counter_errors, "counter"),
        (row.other_errors, "bad"),
    ]
    shown = [f"{label} {count}" for count, label in counts if count]
    return Text(" ".join(shown), style=ERROR_STYLE) if shown else Text("-", style="dim")


def snapshot_table(rows: list[MessageRow], title: str) -> Table:
    """Every row as one rich table (``bywire monitor --once``)."""
    table = Table(*COLUMNS, title=title, title_justify="left", box=None, pad_edge=False)
    for row in rows:
        table.add_row(*cells(row))
    return table
