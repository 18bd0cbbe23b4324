"""The `bywire dashboard` terminal program (textual): the feed's newest state, 4 times a second.

The app reads decoded `/bywire/state` messages from a `FeedSource` (the Foxglove client) and
never touches a controller; it fits an 80×24 terminal. `q` (or Ctrl-C) quits the view with exit
status 0 (`bywire run --dashboard` takes that as the operator's stop); once the feed has ended
the last picture stays on screen, with the reason in the title bar.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar, Protocol

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import BindingType
from textual.containers import Horizontal
from textual.widgets import DataTable, Footer, Header, Static

from bywire.dashboard.snapshot import from_state
from bywire.dashboard.view import (
    TASK_COLUMNS,
    actuator_panel,
    command_panel,
    flags_line,
    idle_cells,
    input_panel,
    mode_panel,
    task_cells,
)
from bywire.quit_keys import QUIT_BINDINGS

REFRESH_S = 0.25
PANELS = {"mode": "mode", "commands": "command", "actuators": "actuators", "inputs": "inputs"}


class FeedSource(Protocol):
    """What the view reads: the newest state message and a status line."""

    def latest(self) -> dict[str, Any] | None: ...

    @property
    def status(self) -> str: ...


Verdict = Callable[[], str | None]
"""The scenario's verdict once its run has ended ("PASSED (7 of 7 passed)"), else None."""


class DashboardApp(App[None]):
    """Panels for mode and flags, command, actuators and inputs; the task table below."""

    TITLE = "bywire dashboard"
    BINDINGS: ClassVar[list[BindingType]] = [*QUIT_BINDINGS]  # q and Ctrl-C
    CSS = """
    Horizontal { height: 6; }
    .panel { border: round $primary; padding: 0 1; width: 1fr; height: 6; }
    #mode { border: round $accent; }
    #flags { height: auto; padding: 0 1; }
    #tasks { height: auto; border: round $primary; }
    """

    def __init__(
        self, feed: FeedSource, *, source: str = "", verdict: Verdict | None = None
    ) -> None:
        """`verdict`: for a scenario the view started, its verdict once the run has ended."""
        super().__init__()
        self.feed = feed
        self._verdict = verdict
        self._source = source
        self.sub_title = source
        self._rows: set[str] = set()

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal():
            yield Static(Text("waiting for the feed…"), id="mode", classes="panel")
            yield Static(id="commands", classes="panel")
        with Horizontal():
            yield Static(id="actuators", classes="panel")
            yield Static(id="inputs", classes="panel")
        yield Static(id="flags")
        yield DataTable(id="tasks", cursor_type="none", show_cursor=False)
        yield Footer()

    def on_mount(self) -> None:
        for panel, title in PANELS.items():
            self.query_one(f"#{panel}", Static).border_title = title
        table = self.query_one(DataTable)
        table.border_title = "tasks"
        for column in TASK_COLUMNS:
            table.add_column(column, key=column)
        self.refresh_view()
        self.set_interval(REFRESH_S, self.refresh_view)

    def refresh_view(self) -> None:
        """Show the newest state; keep the last one on screen once the feed has ended."""
        self.sub_title = " · ".join(part for part in (self._source, self.feed.status) if part)
        verdict = None if self._verdict is None else self._verdict()
        state = self.feed.latest()
        if state is None:
            return
        snap = from_state(state)
        self.query_one("#mode", Static).update(mode_panel(snap))
        self.query_one("#flags", Static).update(flags_line(snap, verdict))
        self.query_one("#commands", Static).update(command_panel(snap))
        self.query_one("#actuators", Static).update(actuator_panel(snap))
        self.query_one("#inputs", Static).update(input_panel(snap))
        table = self.query_one(DataTable)
        for cells in [task_cells(row) for row in snap.tasks] + [idle_cells(snap)]:
            self._show_row(table, cells)

    def _show_row(self, table: DataTable[str], cells: tuple[str, ...]) -> None:
        key = cells[0]
        if key not in self._rows:
            table.add_row(*cells, key=key)
            self._rows.add(key)
            return
        for column, cell in zip(TASK_COLUMNS, cells, strict=True):
            table.update_cell(key, column, cell)
