"""B3's books (docs/SAFETY.md): what `/diagnostics` owes for the set-points the ROS 2 bridge did
not use, and whether it has shown them. One definition for the two judges of it: the oracle's
B3 (`sim/verify/oracle/bridge.py`) and a scenario's `bridge_unshown_drop` (`sim/bridge_computer`),
so that a B3 finding written as a scenario fails on replay. Pure: told each offer and each
period, on the simulated clock.

A set-point refused at arrival is owed at once: `commands_refused`, and its reason's count
(`refused_<reason>`), one more than /diagnostics showed when it came. A period in which the
bridge stops although its planner keeps publishing is owed one more than the count at the last
period that drove with a set-point. Each is due within `GRACE_S`, with the inputs status WARN
or ERROR; a link silent for more than two periods had no period to show it in, and owes
nothing from before.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.ros2.bridge import Activity
from bywire.ros2.diagnostics import Level, inputs_status
from bywire.ros2.link import Snapshot
from bywire.ros2.setpoint import Refusal
from bywire.teleop.frames import SEND_PERIOD_S

GRACE_S = 2 * SEND_PERIOD_S
"""/diagnostics shows what it owes within two of the bridge's periods."""


@dataclass(frozen=True, slots=True)
class Unshown:
    """What /diagnostics owes past its due time, and what it shows."""

    refused: int
    required: int
    seen_by_reason: dict[str, int]
    due_by_reason: dict[str, int]
    level: Level


@dataclass(slots=True)
class RefusalBooks:
    """The newest offer, the count /diagnostics must reach and by when."""

    last_offer_s: float | None = None
    seen: int = 0  # commands_refused at the latest period
    when_used: int = 0  # … at the latest period that drove with the planner's set-point
    required: int = 0
    due_s: float | None = None
    by_reason: dict[Refusal, int] = field(default_factory=dict)  # each reason's count due
    seen_by_reason: dict[str, int] = field(default_factory=dict)  # … at the latest period
    last_period_s: float | None = None

    def offered(self, at_s: float, refusal: Refusal | None) -> None:
        """The planner offered a set-point at `at_s`; `refusal`: why the link refused it."""
        self.last_offer_s = at_s
        if refusal is not None:
            self.required = max(self.required, self.seen) + 1
            counted = self.seen_by_reason.get(refusal.name, 0)
            self.by_reason[refusal] = max(self.by_reason.get(refusal, 0), counted) + 1
            if self.due_s is None:
                self.due_s = at_s + GRACE_S

    def period(
        self, activity: Activity, snapshot: Snapshot, publishing: bool, now: float
    ) -> Unshown | None:
        """One period of the link, its decision's `activity` and the link's `snapshot`, with the
        planner `publishing` or not: what /diagnostics owes past its due time (None: nothing,
        or not yet due)."""
        if self.last_period_s is not None and now - self.last_period_s > 2 * SEND_PERIOD_S:
            self.due_s = None  # the link was silent: it had no period to show it in
        self.last_period_s = now
        health = snapshot.health
        live = self.last_offer_s is not None and publishing
        if activity is Activity.DRIVING:
            self.when_used = health.refused
        elif snapshot.engaged and activity is Activity.STOPPING and live:
            self.required = max(self.required, self.when_used + 1)
            if self.due_s is None:
                self.due_s = now + GRACE_S
        self.seen = health.refused
        self.seen_by_reason = dict(health.refused_by_reason)
        level = inputs_status(health, snapshot.robot_status_report).level
        by_reason = all(
            self.seen_by_reason.get(reason.name, 0) >= due for reason, due in self.by_reason.items()
        )
        shown = health.refused >= self.required and by_reason
        if shown and level in (Level.WARN, Level.ERROR):
            self.due_s = None
            return None
        if self.due_s is None or now <= self.due_s + 1e-9:
            return None
        due = {reason.name: n for reason, n in self.by_reason.items()}
        return Unshown(health.refused, self.required, dict(self.seen_by_reason), due, level)

    def forgive(self) -> None:
        """What was owed is settled (judged once): from now on only what is owed anew."""
        self.due_s, self.required, self.by_reason = None, self.seen, {}
