"""The simulated E-stop button: normally closed, the line pulled down, read as the hardware is.

The line is high only while the circuit is closed: released, the wire whole, and no bounce in
progress. `press`/`release` are the operator's; `break_wire`/`mend_wire` the cable's; `chatter` is a
press whose contact bounces: the next `count` reads alternate open, closed, open..., starting
open, and the button stays pressed.

Like the Linux backend (which reads the line's edge events), a read also reports an opening
that came and went since the read before: a press shorter than a control period is not missed.
"""

from __future__ import annotations


class SimEstopButton:
    """A `DigitalIn`: the E-stop's line."""

    def __init__(self) -> None:
        self.pressed = False
        self.wire_broken = False
        self.chatter_reads = 0
        self.reads = 0
        self.opened_since_read = False

    def get(self) -> bool:
        self.reads += 1
        opened, self.opened_since_read = self.opened_since_read, False
        if self.chatter_reads > 0:
            self.chatter_reads -= 1
            return self.chatter_reads % 2 == 1  # the first of them open (low)
        return not (opened or self.pressed or self.wire_broken)

    def press(self) -> None:
        self.pressed = self.opened_since_read = True

    def release(self) -> None:
        self.pressed = False

    def break_wire(self) -> None:
        self.wire_broken = self.opened_since_read = True

    def mend_wire(self) -> None:
        self.wire_broken = False

    def chatter(self, count: int) -> None:
        """A press that bounces: the next `count` reads alternate, open first; then pressed."""
        self.pressed = True
        self.chatter_reads = count
