"""Supervised timing: every loop pass, port write and DAC transfer has a budget (R-TIMING).

Exceeding one is a fault, not just a counter: the controller cannot keep its deadlines (a fault
to safe outputs within its threshold plus one control period) when its passes take longer than
a control period, or a write hangs in a driver. Overruns are counted in a leaky level, each by
how many budgets it took (an 80 ms pass against 20 ms adds 4, a 25 ms one 1.25; a pass on time
takes `LEAK` away): at `LIMIT` the decision's `timing_fault` condition rises (STOP latched as
Cause.TIMING, category 0: a controlled stop needs a loop that keeps time) and holds until the
level has drained. So one pass that a busy machine delayed by a few milliseconds is no STOP, and
a loop that crawls is one at its first crawling pass. A slow DAC transfer counts against the
DAC the same way (`bywire.runtime.actuators`): the drive is suspect.

The loop also feeds the watchdog only after a pass that kept time (started within the pass
budget of its deadline and finished within it), so a loop that keeps running but keeps missing
its deadlines trips the watchdog as a stalled one does.

Times are the hardware clock's (`Clock.now`), so budgets hold on the simulator's virtual time
(where a stalled write lets simulated time run) as on the robot.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from bywire.runtime.recent_fault import RecentFault


@dataclass(frozen=True, slots=True)
class Budgets:
    """How long each kind of work may take (`[timeouts]` in the robot file, the same names).

    `pass_budget_s`: one pass of the loop, from its wake-up to its last write; also how late a
    pass may start after its deadline and still count as on time. `write_budget_s`: one port
    write (GPIO line, PWM channel). `dac_transfer_budget_s`: one I2C transfer to the DAC (a
    3-byte write takes 0.3 ms at 100 kHz; 2 ms transfers are ordinary, 80 ms ones are not). The
    defaults are what the stop promises leave (`bywire.config.deadlines.STOP_PROMISES`): a pass
    within its budget, and its two transfers within theirs, never holds a stop back past its
    deadline."""

    pass_budget_s: float = 0.007
    write_budget_s: float = 0.005
    dac_transfer_budget_s: float = 0.0035


LIMIT = 3.0
"""Budgets overrun (in budgets' worth) that make the timing fault."""
LEAK = 0.25
"""What each pass on time takes away from the level."""


def overrun_weight(spent_s: float, budget_s: float) -> float:
    """How much an overrun counts: the budgets it took, at least one."""
    return max(spent_s / budget_s, 1.0)


@dataclass(slots=True)
class Overruns:
    """What overran its budget, how often and by how much at worst; the leaky `level` and the
    condition it makes (`active`); `recent` flags any overrun for a while (TASK_OVERRUN)."""

    budgets: Budgets = field(default_factory=Budgets)
    recent: RecentFault = field(default_factory=RecentFault)
    counts: Counter[str] = field(default_factory=Counter)
    worst_s: dict[str, float] = field(default_factory=dict)
    level: float = 0.0
    escalated: bool = False

    def check(self, what: str, spent_s: float, budget_s: float, now: float) -> bool:
        """Account `spent_s` of work of kind `what` against `budget_s`; True when it overran."""
        if spent_s <= budget_s:
            return False
        self.counts[what] += 1
        self.worst_s[what] = max(self.worst_s.get(what, 0.0), spent_s)
        self.recent.happened(now)
        self.level = min(self.level + overrun_weight(spent_s, budget_s), 2 * LIMIT)
        if self.level >= LIMIT:
            self.escalated = True
        return True

    def on_time(self) -> None:
        """A pass kept its budget: the level drains, and the fault clears once it is empty."""
        self.level = max(self.level - LEAK, 0.0)
        if self.level == 0.0:
            self.escalated = False

    def active(self, _now: float | None = None) -> bool:
        """The decision's `timing_fault`: overruns reached `LIMIT` and have not drained."""
        return self.escalated
