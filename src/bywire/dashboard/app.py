"""The `bywire dashboard` terminal program (textual): the feed's latest snapshot, 4 times a second.

The app never touches the runtime: it reads immutable snapshots from the feed, and on exit calls
`on_exit` (the live run's stop, which asks the controller to stop and write its safe outputs).
"""

from __future__ import annotations

from collections.abc import Callable

from rich.text import Text
from textual.app import App, ComposeResult
from textual.containers import Horizontal
from textual.widgets import DataTable, Footer, Header, Static

from bywire.dashboard.feed import SnapshotFeed
from bywire.dashboard.view import (
    TASK_COLUMNS,
    actuator_panel,
    command_panel,
    idle_cells,
    input_panel,
    mode_panel,
    task_cells,
)

REFRESH_S = 0.25
PANELS = ("mode", "commands", "actuators", "inputs")


class DashboardApp(App[None]):
    """Panels for mode and flags, commands, actuators and inputs; the task table below."""

    TITLE = "bywire dashboard"
    BINDINGS = [("q", "quit", "Quit (controller stops, outputs safe)")]  # noqa: RUF012 -- textual's
    CSS = """
    Horizontal { height: auto; }
    Static { border: round $primary; padding: 0 1; width: 1fr; height: auto; }
    #mode { border: round $accent; }
    #tasks { height: auto; border: round $primary; }
    """

    def __init__(
        self,
        feed: SnapshotFeed,
        *,
        source: str = "",
        on_exit: Callable[[], object] | None = None,
    ) -> None:
        super().__init__()
        self.feed = feed
        self.sub_title = source
        self._source = source
        self._on_exit = on_exit
        self._rows: set[str] = set()

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal():
            yield Static(Text("waiting for the controller…"), id="mode")
            yield Static(id="commands")
        with Horizontal():
            yield Static(id="actuators")
            yield Static(id="inputs")
        yield DataTable(id="tasks", cursor_type="none")
        yield Footer()

    def on_mount(self) -> None:
        for panel, title in zip(PANELS, ("mode", "command", "actuators", "inputs"), strict=True):
            self.query_one(f"#{panel}", Static).border_title = title
        table = self.query_one(DataTable)
        table.border_title = "tasks"
        for column in TASK_COLUMNS:
            table.add_column(column, key=column)
        self.refresh_view()
        self.set_interval(REFRESH_S, self.refresh_view)

    def on_unmount(self) -> None:
        if self._on_exit is not None:
            self._on_exit()

    def refresh_view(self) -> None:
        """Show the newest snapshot; keep the last one on screen once the run has ended."""
        snap, status = self.feed.latest(), self.feed.status
        if status is not None:
            self.sub_title = f"{self._source} · {status}"
        if snap is None:
            return
        self.query_one("#mode", Static).update(mode_panel(snap, status))
        self.query_one("#commands", Static).update(command_panel(snap))
        self.query_one("#actuators", Static).update(actuator_panel(snap))
        self.query_one("#inputs", Static).update(input_panel(snap))
        rows = [task_cells(row) for row in snap.tasks] + [idle_cells(snap)]
        table = self.query_one(DataTable)
        for cells in rows:
            self._show_row(table, cells)

    def _show_row(self, table: DataTable[str], cells: tuple[str, ...]) -> None:
        key = cells[0]
        if key not in self._rows:
            table.add_row(*cells, key=key)
            self._rows.add(key)
            return
        for column, cell in zip(TASK_COLUMNS, cells, strict=True):
            table.update_cell(key, column, cell)
