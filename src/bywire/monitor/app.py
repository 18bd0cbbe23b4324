"""The live `bywire monitor`: a textual app with the message table, redrawn 4 times a second."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import ClassVar

from textual.app import App, ComposeResult
from textual.binding import BindingType
from textual.widgets import DataTable, Footer, Header

from bywire.monitor.bus_reader import CanFeed
from bywire.monitor.bus_state import BusModel
from bywire.monitor.view import COLUMNS, cells
from bywire.quit_keys import QUIT_BINDINGS

REFRESH_S = 0.25


class MonitorApp(App[None]):
    """Frames from ``feed`` into ``model``; one table row per id, keyed by the id."""

    TITLE = "bywire monitor"
    BINDINGS: ClassVar[list[BindingType]] = [*QUIT_BINDINGS]  # q and Ctrl-C

    def __init__(
        self,
        feed: CanFeed,
        model: BusModel,
        source: str,
        clock: Callable[[], float] = time.time,
    ) -> None:
        super().__init__()
        self.feed = feed
        self.model = model
        self.source = source
        self.sub_title = source
        self._clock = clock
        self._shown: set[int] = set()

    def compose(self) -> ComposeResult:
        yield Header()
        yield DataTable(id="messages", zebra_stripes=True, cursor_type="row")
        yield Footer()

    def on_mount(self) -> None:
        table = self.query_one(DataTable)
        for column in COLUMNS:
            table.add_column(column, key=column)
        self.set_interval(REFRESH_S, self.refresh_table)

    def refresh_table(self) -> None:
        """Take the frames that arrived and redraw every row."""
        for message in self.feed.drain():
            self.model.add(message.arbitration_id, bytes(message.data), message.timestamp)
        table = self.query_one(DataTable)
        for row in self.model.rows(self._clock()):
            key = str(row.arbitration_id)
            if row.arbitration_id not in self._shown:
                table.add_row(*cells(row), key=key)
                self._shown.add(row.arbitration_id)
                continue
            for column, cell in zip(COLUMNS, cells(row), strict=True):
                table.update_cell(key, column, cell)
        self.sub_title = f"{self.source} · {self.feed.connection} · {self.model.frames} frames"
