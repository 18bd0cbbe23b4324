"""The live `bywire rc` (textual): the channel table, the status line and the suggestion as TOML,
redrawn 10 times a second.

`q` or Ctrl-C quits (the command then prints the suggestion); `r` forgets what was seen (ranges
and rests) and starts over, as after moving the transmitter's trims or end points.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.widgets import DataTable, Footer, Header, Static

from bywire.quit_keys import QUIT_BINDINGS
from bywire.rc.ibus_reading import RcSession
from bywire.rc.sources import ByteSource
from bywire.rc.suggestion import Suggestion
from bywire.rc.view import COLUMNS, rows, status

REFRESH_S = 0.1

Snippet = Callable[[Suggestion], str]
"""The suggestion as the TOML text the view shows (and the command prints on quit)."""


class RcApp(App[None]):
    """Bytes from `source` into `session`; one table row per IBUS channel."""

    TITLE = "bywire rc"
    BINDINGS: ClassVar[list[BindingType]] = [
        *QUIT_BINDINGS,  # q and Ctrl-C
        Binding("r", "reset", "Start over"),
    ]
    CSS = """
    #status { height: auto; padding: 0 1; }
    #channels { height: auto; }
    #suggestion-box { border: round $primary; height: 1fr; }
    """

    def __init__(self, source: ByteSource, session: RcSession, snippet: Snippet) -> None:
        super().__init__()
        self.source = source
        self.session = session
        self._snippet = snippet
        self.sub_title = source.name

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(id="status")
        yield DataTable(id="channels", cursor_type="none", show_cursor=False)
        with VerticalScroll(id="suggestion-box"):
            yield Static(id="suggestion")
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#suggestion-box").border_title = "suggestion (printed on quit)"
        table = self.query_one(DataTable)
        for column in COLUMNS:
            table.add_column(column, key=column)
        for index, cells in enumerate(rows(self.session, self.session.suggestion())):
            table.add_row(*cells, key=str(index))
        self.refresh_view()
        self.set_interval(REFRESH_S, self.refresh_view)

    def refresh_view(self) -> None:
        """Take the bytes that arrived and redraw."""
        self.session.feed(self.source.read(), self.source.now())
        suggestion = self.session.suggestion()
        problem = self.source.problem
        self.query_one("#status", Static).update(
            status(self.session, self.source.name, problem, self.source.now())
        )
        table = self.query_one(DataTable)
        for index, cells in enumerate(rows(self.session, suggestion)):
            for column, cell in zip(COLUMNS, cells, strict=True):
                table.update_cell(str(index), column, cell)
        self.query_one("#suggestion", Static).update(Text(self._snippet(suggestion)))

    def action_reset(self) -> None:
        self.session.reset()
        self.refresh_view()
