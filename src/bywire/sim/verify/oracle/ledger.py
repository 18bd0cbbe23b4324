"""The stop ledger: every request for STOP the oracle was told of, and the deadline by which the
outputs must be safe; what only the operator's switch may clear (S8) and from when.

H1 asks it whether the outputs may drive (armed, or a stop whose deadline has not passed); an
arming act (`ArmingTracker`) clears it; a CAN re-enable may not while something it lists as
owed to the switch (`owed`) is latched for sure.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from bywire.sim.verify.oracle.causes import (
    CAN_MODE_ONLY,
    CAN_ONLY,
    POWER_OFF,
    RC_BORNE,
    SWITCH_ONLY,
    OracleCause,
)
from bywire.sim.verify.oracle.delays import Delays
from bywire.sim.verify.oracle.faults_in_force import FaultsInForce
from bywire.sim.verify.oracle.requirements import DAC_LATCH_WRITES

LINK_SILENCES = frozenset({OracleCause.RC_LINK_LOST})
"""A lost link carries no frames: no RC-borne cause arrives while it is lost…"""
LINK_AND_FAILSAFE_SILENCE = frozenset({OracleCause.RC_LINK_LOST, OracleCause.RC_FAILSAFE})
"""…and failsafe frames carry no switch position either."""


@dataclass(frozen=True, slots=True)
class Demand:
    """What H1 allows: armed, until when the outputs may still drive, and what set that."""

    armed: bool
    deadline_s: float | None
    stopped_by: frozenset[OracleCause]


@dataclass(frozen=True, slots=True)
class PassingStop:
    """A stop demanded by frames still to be sent (implausible ones), undone if corruption that
    begins before the first of them goes out may take them all, and nothing else moved H1."""

    at_s: float
    last_sent_s: float
    before: Demand
    after: Demand


@dataclass(frozen=True, slots=True)
class UncountedStop:
    """A stop that causes of CAN mode only demand of a move to CAN the controller has not
    counted yet (it counts by `counts_s`, after the debounce's frames), and what H1 allowed
    before it: restored if the causes, and their effect on the controller, are over sooner."""

    before: Demand
    counts_s: float


@dataclass(slots=True)
class StopLedger:
    """The stops requested, their deadline, and what they leave latched."""

    timing: OracleTiming
    faults: FaultsInForce
    delays: Delays
    armed: bool = False
    deadline_s: float | None = None  # the outputs may drive until then (None: not at all)
    stopped_by: set[OracleCause] = field(default_factory=set)  # what set `deadline_s`
    power_off_by: dict[OracleCause, float] = field(default_factory=dict)  # a cause that makes the
    # drive suspect, and when it has surely been acted on (until the next arming)
    tripped_at: float | None = None  # the watchdog tripped then, not yet acknowledged at STOP
    owed: dict[OracleCause, float] = field(default_factory=dict)  # the switch's to clear, from then
    passing: PassingStop | None = None  # the latest implausible frames' stop
    rc_borne_at: float = -1.0  # when a cause the IBUS frames carry last happened
    uncounted: UncountedStop | None = None  # demanded of a move to CAN not yet counted

    # --- requests and armings ----------------------------------------------------------------

    def request(self, cause: OracleCause, now: float, counts_from_s: float = 0.0) -> None:
        """Something that demands STOP happened at `now` (what IBUS frames carry only counts
        while frames arrive: a lost link has its own, longer deadline); the controller can act
        on it no sooner than `counts_from_s` (a switch's move, once its debounce's frames have
        shown it)."""
        silenced = LINK_AND_FAILSAFE_SILENCE if cause is OracleCause.SWITCH_STOP else LINK_SILENCES
        if cause in RC_BORNE and self.faults.any_of(silenced):
            return
        if cause in CAN_MODE_ONLY and counts_from_s > now and self.uncounted is None:
            self.uncounted = UncountedStop(self.demand(), counts_from_s)
        rc_blind_until = self.delays.rc_blind_until
        if cause is OracleCause.RC_IMPLAUSIBLE and now > rc_blind_until:
            self.owed[cause] = now + self.timing.deadline_s(cause)
        # Frames being corrupted may hide the cause until they are over.
        blind_until = rc_blind_until if cause in RC_BORNE else now
        deadline = max(now, blind_until) + self.timing.deadline_s(cause)
        deadline = self.delays.past_hang(now, max(deadline, counts_from_s))
        if cause in RC_BORNE:
            self.rc_borne_at = now
        if cause in POWER_OFF:
            self.power_off_by[cause] = min(deadline, self.power_off_by.get(cause, deadline))
        if self.armed:
            self.armed, self.deadline_s, self.stopped_by = False, deadline, {cause}
        elif self.deadline_s is not None:
            self.deadline_s = min(self.deadline_s, deadline)
            self.stopped_by.add(cause)

    def arm(self) -> None:
        """A deliberate act: nothing demands STOP any more, and what a category 0 cause demanded
        is over, even when a move to STOP follows at once (an arming the debounce completed
        just before the switch left)."""
        self.armed, self.deadline_s = True, None
        self.power_off_by.clear()
        self.uncounted = None

    def demand(self) -> Demand:
        return Demand(self.armed, self.deadline_s, frozenset(self.stopped_by))

    def restore(self, demand: Demand) -> None:
        self.armed, self.deadline_s = demand.armed, demand.deadline_s
        self.stopped_by = set(demand.stopped_by)

    def reinstate(self, deadline_s: float, stopped_by: frozenset[OracleCause]) -> None:
        """A stop already on its way keeps its own deadline (a glimpse of STOP no frame showed
        did not bring it on)."""
        self.deadline_s, self.stopped_by = deadline_s, set(stopped_by)

    def allows(self, now: float) -> bool:
        """Armed, or a stop whose deadline has not passed."""
        return self.armed or (self.deadline_s is not None and now < self.deadline_s)

    def can_mode_fault_over(self, clear_s: float) -> None:
        """The last cause of CAN mode only in force is over, and its effect on the controller
        (a distrusted id) by `clear_s`: if that may be before the move to CAN counts, the
        controller may enter CAN with nothing to stop it (nothing latched in the mode it was
        in), and what H1 allowed before the stop is allowed again (found by `bywire verify` on
        a 10 Hz receiver with a debounce of 9 frames; docs/SAFETY.md row 78)."""
        uncounted, self.uncounted = self.uncounted, None
        if uncounted is None or clear_s >= uncounted.counts_s:
            return
        if self.stopped_by <= CAN_MODE_ONLY:
            self.restore(uncounted.before)

    def can_stop_pending(self, now: float) -> bool:
        """Only CAN-bound causes demand STOP, and the controller may not have acted yet."""
        deadline = self.deadline_s
        return deadline is not None and now < deadline and self.stopped_by <= CAN_ONLY

    @property
    def power_off_from(self) -> float | None:
        """From when a cause that makes the drive suspect has surely been acted on."""
        return min(self.power_off_by.values(), default=None)

    def power_off_demanded(self, now: float) -> bool:
        """A cause that makes the drive suspect has surely been acted on (its deadline passed):
        category 0 from then until the next arming."""
        due = (self.power_off_from, self.tripped_at)
        return any(from_s is not None and now >= from_s for from_s in due)

    def postpone(self) -> None:
        """A hang began: a stop not yet acted on waits for the loop to run again."""
        if self.deadline_s is not None:
            self.deadline_s = self.delays.past_hang(-1.0, self.deadline_s)

    # --- implausible frames, which corruption may take whole ---------------------------------

    def implausible(self, frames: int, now: float) -> None:
        """The next `frames` IBUS frames carry a pulse no stick gives."""
        if self.delays.all_may_be_lost(frames, now):
            return
        before = self.demand()
        self.request(OracleCause.RC_IMPLAUSIBLE, now)
        last_sent_s = now + frames * self.timing.frame_s
        self.passing = PassingStop(now, last_sent_s, before, self.demand())

    def rc_blind(self, from_s: float, until_s: float) -> None:
        """IBUS frames may be lost from `from_s` to `until_s`: implausible frames not yet sent
        when the corruption began may never be seen, nor may every frame of the passing stop."""
        if self.owed.get(OracleCause.RC_IMPLAUSIBLE, -1.0) >= from_s:
            del self.owed[OracleCause.RC_IMPLAUSIBLE]
        passing, self.passing = self.passing, None
        if passing is None:
            return
        first_unsent = from_s <= passing.at_s + self.timing.frame_s
        if first_unsent and passing.last_sent_s <= until_s and self.demand() == passing.after:
            self.restore(passing.before)

    # --- what only the switch may clear ------------------------------------------------------

    def latched_from(self, cause: OracleCause) -> float | None:
        """From when the fault `cause`, if it lasts, has latched its cause whatever the
        controller's timing (None: not one that only the switch clears, or never for sure)."""
        began = self.faults.began
        if cause is OracleCause.CAN_IMPOSTOR and cause in began:
            return self._impostor_latched_from()
        if cause not in SWITCH_ONLY or cause not in began:
            return None
        began_s = began[cause][0]
        if cause is OracleCause.DAC_FAIL:  # counted only while the loop's writes reach the DAC
            latch_s = DAC_LATCH_WRITES * self.timing.driving_period_s
            return max(began_s, self.faults.dac_writes_from) + latch_s
        if (
            cause is OracleCause.RC_FAILSAFE
        ):  # carried by frames: none while lost, late if corrupted
            if OracleCause.RC_LINK_LOST in self.faults:
                return None
            began_s = max(began_s, self.delays.rc_blind_until)
        return began_s + self.timing.deadline_s(cause)

    def _impostor_latched_from(self) -> float | None:
        """A second sender latches CAN_UNTRUSTED for sure when it began while the robot drove
        in CAN mode (the switch at CAN, the motors enabled: being allowed to drive is not
        enough, a glimpse of STOP may have left it standing) and nothing else has stopped it
        since: each of its frames takes the real computer's next counter, so every real frame
        after it is a repeat, and three repeats among sixteen frames distrust the id while the
        mode is still CAN; begun while a move to CAN was still being counted (the robot in
        RC), it latches once the move counts, if it lasts that long. (Begun at STOP, the cause
        never latches; with the computer silent,
        nothing repeats; with another stop first, the robot may have left CAN mode before the
        id was distrusted.)"""
        began_s, armed = self.faults.began[OracleCause.CAN_IMPOSTOR]
        if not (armed and self.faults.impostor_met_drive):
            return None
        if self.stopped_by != {OracleCause.CAN_IMPOSTOR}:
            return None
        latched_s = began_s + self.timing.deadline_s(OracleCause.CAN_IMPOSTOR)
        latched_s = max(latched_s, self.faults.impostor_counts_s)  # in CAN mode by then
        return self.delays.past_hang(began_s, latched_s)

    def passed_unseen(self, cause: OracleCause) -> None:
        """The fault `cause` ended before the controller could have noticed it: what it demanded
        of the drive's power is withdrawn (a DAC failing for two writes latches nothing, and a
        controlled stop under way may keep the drive powered)."""
        self.power_off_by.pop(cause, None)

    def ended(self, cause: OracleCause, now: float) -> None:
        """The fault `cause` ended at `now` (before `faults.began` forgets it): what it surely
        latched is the switch's to clear."""
        latched_s = self.latched_from(cause)
        if latched_s is not None and latched_s < now:
            self.owed[cause] = latched_s

    def owed_now(self, now: float) -> set[OracleCause]:
        """What only the switch may clear now: latched for sure since the switch's last visit
        to STOP, whether over or still in force."""
        owed = {cause for cause, since_s in self.owed.items() if since_s < now}
        for cause in self.faults.causes:
            latched_s = self.latched_from(cause)
            if latched_s is not None and latched_s < now:
                owed.add(cause)
        return owed

    def tripped(self, trips_at_s: float) -> None:
        """The watchdog trips at `trips_at_s`: only the switch acknowledges it."""
        self.tripped_at = trips_at_s
        self.owed[OracleCause.WATCHDOG] = trips_at_s
