"""The keys that quit every terminal view of bywire (monitor, teleop, dashboard): q and Ctrl-C.

Textual binds Ctrl-C to a hint ("press ctrl+q to quit"), so a user's first Ctrl-C did nothing;
every tool of this field quits on it, and teleop is a driving tool. The binding has priority, so
no focused widget can take the key first.
"""

from __future__ import annotations

from textual.binding import Binding, BindingType

QUIT_BINDINGS: list[BindingType] = [
    Binding("q", "quit", "Quit"),
    Binding("ctrl+c", "quit", "Quit", show=False, priority=True),
]
