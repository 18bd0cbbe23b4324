"""The E-stop on a key: `bywire sim --realtime` at a terminal, `e` presses and releases it.

The safety operator's button (issue 44) for a person watching the simulated robot live (with
`bywire teleop`, Foxglove or the dashboard): `e` presses the simulated robot's E-stop, `e` again
releases it (the robot stays stopped until the mode switch goes through STOP). The terminal is
read in cbreak mode by a thread the background owner starts; it restores the terminal on the
way out. The simulated button is two flags the run's decisions read.
"""

from __future__ import annotations

import contextlib
import os
import select
import termios
import threading
import tty
from collections.abc import Callable, Iterator
from typing import TextIO

from bywire.background import OWNER
from bywire.hal.simulated.estop import SimEstopButton

ESTOP_KEY = "e"
POLL_S = 0.1  # how soon the reader notices the run is over
JOIN_S = 1.0


def on_key(button: SimEstopButton, key: str) -> str | None:
    """What `key` does to the button: the line to show, or None for any other key."""
    if key.lower() != ESTOP_KEY:
        return None
    if button.pressed:
        button.release()
        return "E-stop released: move the mode switch through STOP to drive again"
    button.press()
    return "E-stop pressed"


@contextlib.contextmanager
def estop_key(
    button: SimEstopButton, terminal: TextIO, say: Callable[[str], None]
) -> Iterator[None]:
    """While inside, each `e` typed on `terminal` toggles `button` (and says so)."""
    fd = terminal.fileno()
    saved = termios.tcgetattr(fd)
    done = threading.Event()

    def read_keys() -> None:
        while not done.is_set():
            try:
                ready, _, _ = select.select([fd], [], [], POLL_S)
                key = os.read(fd, 1).decode(errors="replace") if ready else ""
            except OSError:  # the terminal went away: no more keys
                return
            line = on_key(button, key) if key else None
            if line is not None:
                say(line)

    tty.setcbreak(fd)
    reader = OWNER.thread(read_keys, name="bywire-estop-key", stop=done.set)
    try:
        yield
    finally:
        done.set()
        reader.join(JOIN_S)
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
