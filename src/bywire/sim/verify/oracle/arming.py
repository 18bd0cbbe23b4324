"""The arming tracker: where the mode switch is and has been, what each source asks for, and
when an arming act (the switch held at STOP and moved to a source at zero throttle, or a CAN
re-enable at CAN) has happened, or may have, given the debounce and frames that may be lost.

An arming clears the stop ledger (`StopLedger.arm`) unless a fault that must refuse it has been
in force a while. A source that takes over (the switch settled on it, or a re-enable) is handed
to H9 (`taking`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.model import ControlMode
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.checks.h9 import TakeOver
from bywire.sim.verify.oracle.delays import Delays
from bywire.sim.verify.oracle.faults_in_force import FaultsInForce
from bywire.sim.verify.oracle.ledger import Demand, StopLedger
from bywire.sim.verify.oracle.requirements import CAN_STALE_S

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP
STALE_S = {RC: 0.0, CAN: CAN_STALE_S}
"""How long a source's old value may still be what the controller sees after it changed: one
command period plus wire time for CAN; none for RC, whose switch and sticks share each frame."""


@dataclass(slots=True)
class SourceState:
    """What one source (RC or CAN) asks for, and its throttle's history."""

    steering_norm: float = 0.0
    throttle_norm: float = 0.0
    seen_zero: bool = True  # at zero throttle since the switch moved to it
    left_zero_at: float = -1.0  # when the throttle last went from zero to non-zero


@dataclass(frozen=True, slots=True)
class BeforeStop:
    """What H1 allowed as the switch last went to STOP, and where it came from: a glimpse of
    STOP that no frame showed leaves it so."""

    demand: Demand = field(default_factory=lambda: Demand(False, None, frozenset()))
    source: ControlMode = STOP


@dataclass(frozen=True, slots=True)
class Pending:
    """A move to `mode` at `at_s` that may arm once the debounce's frames have shown it."""

    at_s: float
    mode: ControlMode


@dataclass(slots=True)
class ArmingTracker:
    """The switch's position and history, the sources, and the armings they make."""

    timing: OracleTiming
    ledger: StopLedger
    faults: FaultsInForce
    delays: Delays
    switch: ControlMode = STOP
    switch_at: float = 0.0
    switch_shown_s: float = 0.0  # from when frames may show the switch's position (H2)
    stop_since: float = 0.0  # the switch's hold at STOP began (a glimpse away does not end it)
    between_from: float | None = None  # read between positions since: STOP, no stay (row 72)
    stop_shown_at: float = -1.0  # the switch last left a STOP that a frame may have shown
    gap_hold: tuple[float, float] = (-1.0, float("-inf"))  # back at STOP from between positions
    # then, and the hold at STOP the gap kept (what it held before it; -inf: none)
    chatter_until: float = -1.0  # a bouncing switch's frames read STOP every other one until then
    left_at: dict[ControlMode, float] = field(default_factory=dict)
    pending: Pending | None = None
    before_stop: BeforeStop = field(default_factory=BeforeStop)
    sources: dict[ControlMode, SourceState] = field(
        default_factory=lambda: {RC: SourceState(), CAN: SourceState()}
    )
    taking: TakeOver | None = None  # a source taking over, judged by H9

    # --- the sources -----------------------------------------------------------------------------

    def set_throttle(self, source: ControlMode, throttle_norm: float, now: float) -> None:
        state = self.sources[source]
        if state.throttle_norm == 0.0 and throttle_norm != 0.0:
            state.left_zero_at = now
        state.throttle_norm = throttle_norm
        if throttle_norm == 0.0:
            state.seen_zero = True
        if self.pending is not None and self.pending.mode is source:
            self.pending = None  # changed within the debounce: whether it armed is timing
            self.arm_now(now, source)

    def set_steering(self, source: ControlMode, steering_norm: float) -> None:
        """A new steering while the source takes over ends H9's judgement (a command moves at
        the ordinary rate)."""
        self.sources[source].steering_norm = steering_norm
        if self.taking is not None and self.taking.source is source:
            self.taking = None

    def _taking_over(self, source: ControlMode, now: float) -> None:
        self.taking = TakeOver(source, self.delays.past_hang(now, now + self.timing.settle_s))

    # --- armings ---------------------------------------------------------------------------------

    def arm_now(self, now: float, target: ControlMode) -> None:
        """A deliberate act into `target`, unless a fault that must refuse it has been in
        force a while."""
        if not self.faults.blocking(target is RC, now):
            self.ledger.arm()

    def resolve(self, now: float) -> None:
        """A move whose debounce is over arms if its source is still at zero throttle."""
        pending = self.pending
        if pending is None or now < pending.at_s + self.timing.settle_s:
            return
        self.pending = None
        if self.switch is pending.mode and self.sources[pending.mode].throttle_norm == 0.0:
            self.arm_now(now, pending.mode)

    def re_enable(self, now: float) -> None:
        """A CAN re-enable request (a 0→1 change) was sent: it arms if the controller may see
        the switch at CAN (there, or moved on to RC less than a debounce ago: a move counts
        after its frames; the arming is then a handover) and nothing that the switch alone may
        clear is latched. A move to STOP has its own deadline, which an arming cannot lift.
        Sent while the robot may already drive in CAN, it arms nothing and nothing takes over:
        the steering goes on at its ordinary rate (a new set-point 25 ms before was judged
        at the handover rate)."""
        if self.switch is CAN and not self.ledger.armed:
            self._taking_over(CAN, now)
        left_can_s = now - self.left_at.get(CAN, -1.0)
        leaving = self.switch is RC and left_can_s < self.timing.settle_s
        if (self.switch is CAN or leaving) and not self.ledger.owed_now(now):
            self.arm_now(now, CAN)

    # --- the switch ------------------------------------------------------------------------------

    def chatter(self, frames: int, now: float) -> None:
        """The mode switch bounces: of the next `frames` frames every other one reads STOP."""
        self.chatter_until = now + (frames + 1) * self.timing.frame_s  # and the one in flight
        if not self.delays.all_may_be_lost(frames, now):
            # The last of them reads STOP: an even count starts with a frame at the switch's own
            # position, so the first STOP goes out a frame later (a 19.6 ms frame showed it).
            first_stop_s = now + self.timing.frame_s * (frames % 2 == 0)
            self.ledger.request(OracleCause.SWITCH_STOP, first_stop_s)

    def link(self, lost: bool, now: float) -> None:
        """A link lost before the debounce's frames showed the switch's last move hides the
        move until the link is back (the controller rightly stays where it was)."""
        if lost and now < self.switch_shown_s + self.timing.settle_s:
            self.switch_shown_s = float("inf")
        elif not lost and self.switch_shown_s == float("inf"):
            self.switch_shown_s = now

    def settled_s(self) -> float:
        """From when the controller surely acts on the switch's position: its move travels in
        IBUS frames, which corrupted or lost ones delay."""
        shown_s = max(self.switch_shown_s, self.delays.rc_blind_until)
        return self.delays.past_hang(shown_s, shown_s + self.timing.settle_s)

    def set_between(self, now: float) -> None:
        """The mode switch was read between positions (or beyond the end ones): STOP at once,
        as at the STOP position, but no stay at STOP (docs/SAFETY.md row 72): a hold at the
        STOP position under way ends here (what it held still counts: the controller's
        readiness outlives the gap), and none begins."""
        if self.between_from is not None:
            return
        if self.switch is not STOP:
            held_since = self.stop_since
            self.set_switch(STOP, now)
            if self.stop_since != held_since:  # not back from a glimpse away: no hold began
                self.stop_since = float("inf")
        elif (kept_s := self._gap_kept_s(now)) > float("-inf"):
            self.stop_since = now - kept_s  # the glimpse of STOP between may have gone unseen
        self.between_from = now

    def _gap_kept_s(self, now: float) -> float:
        """The hold at STOP a gap kept, if the switch came back to STOP from it so briefly that
        no frame may have shown STOP (the controller saw the gap, then what follows: the hold
        before the gap still counts, row 72); -inf otherwise. A frame at STOP after a gap
        begins a new stay."""
        back_s, kept_s = self.gap_hold
        return kept_s if self._unseen_since(back_s, now) else float("-inf")

    def _unseen_since(self, moved_s: float, now: float) -> bool:
        """No frame may have shown the position the switch took at `moved_s`: it left sooner
        than a frame (and its wire time), or every frame since may have been lost."""
        return now - moved_s < self.timing.unseen_s or self.delays.hidden(moved_s, now)

    def _held_at_stop_s(self, now: float) -> float:
        """How long the switch has been held at the STOP position (until the gap, if it is
        between positions now; -inf if it reached the gap from a source)."""
        until_s = now if self.between_from is None else self.between_from
        return until_s - self.stop_since

    def set_switch(self, mode: ControlMode, now: float) -> None:
        """The mode switch moved to `mode` (a source it settles on takes over: H9; back to one
        within the debounce, the controller may never have left it)."""
        if self.between_from is not None and mode is STOP:
            self.gap_hold = (now, self._held_at_stop_s(now))
            self.between_from = None  # at the STOP position again: a new hold begins
            self.stop_since = self._stay_begins(now)
            return
        if self.switch is STOP and mode is not STOP and not self._unseen_since(self.switch_at, now):
            self.stop_shown_at = now  # leaving a STOP a frame may have shown
        if mode is not self.switch and mode is not STOP:
            returning = self._returning(mode, now)
            self.taking = None
            if not returning:
                self._taking_over(mode, now)
        if mode is self.switch:
            return  # not a move: the frames do not change
        self.ledger.uncounted = None  # a stop demanded of the last move is the move's affair
        was, entered_s = self.switch, self.switch_at
        if was is STOP:
            held_s = max(self._held_at_stop_s(now), self._gap_kept_s(now))
            if now <= self.chatter_until:  # a bouncing switch's next frame may read STOP too
                held_s += self.timing.frame_s
        else:
            held_s = now - entered_s
        self.between_from = None
        self.switch, self.switch_at = mode, now
        self.switch_shown_s = float("inf") if OracleCause.RC_LINK_LOST in self.faults else now
        self.left_at[was] = now  # via STOP too: a glimpse of STOP may have gone unseen
        if was is STOP:
            # Held at STOP, the switch cleared whatever was over (leaning to allowing: even a
            # glimpse); what is still in force stays latched, and `owed_now` finds it.
            self.ledger.owed.clear()
        if mode is STOP:
            self._to_stop(was, entered_s, held_s, now)
        else:
            self._to_source(mode, was, entered_s, held_s, now)

    def _stay_begins(self, now: float) -> float:
        """When the controller's run of frames at STOP may begin, for a move to the STOP
        position at `now`: among a bouncing switch's frames, the one just before may have read
        STOP too (between positions as well: a bounce reads the STOP position), so a frame
        earlier."""
        return now - self.timing.frame_s if now <= self.chatter_until else now

    def _returning(self, mode: ControlMode, now: float) -> bool:
        """Back to the source `mode` within the debounce, through other sources or STOPs no
        frame may have shown: the controller may never have left `mode` (found by `bywire
        verify` on 10 Hz frames: CAN, a glimpse of STOP, one frame of RC, a glimpse of STOP,
        CAN again; docs/SAFETY.md row 76). A STOP a frame may have shown since means it did."""
        left_s = self.left_at.get(mode, -1.0)
        return self.stop_shown_at < left_s and now - left_s < self.timing.settle_s

    def _to_stop(self, was: ControlMode, entered_s: float, held_s: float, now: float) -> None:
        # Back at STOP after a glimpse away that no frame may have shown: still one hold.
        glimpse = held_s < self.timing.unseen_s and self.left_at.get(STOP) == entered_s
        if not glimpse:
            self.stop_since = self._stay_begins(now)
        if self.ledger.tripped_at is not None:  # the gate opens once the STOP is acknowledged
            self.faults.dac_writes_from = now + self.timing.settle_s
        if self.pending is not None:  # cut short: it may have armed meanwhile
            self.arm_now(now, self.pending.mode)
            self.pending = None
        self.before_stop = BeforeStop(self.ledger.demand(), was)
        self.ledger.request(OracleCause.SWITCH_STOP, now)
        self.ledger.tripped_at = None  # the operator's acknowledgement begins

    def _to_source(
        self, mode: ControlMode, was: ControlMode, entered_s: float, held_s: float, now: float
    ) -> None:
        ledger, before = self.ledger, self.before_stop
        if was is CAN and mode is RC and ledger.can_stop_pending(now):
            # Handed over before the controller could have acted on a CAN-bound fault: RC
            # drives on (CAN-bound causes never block RC).
            ledger.arm()
        source = self.sources[mode]
        # Whether any frame showed STOP is judged on this stretch at STOP alone: a glimpse away
        # joins two stretches into one hold (above), but no frame read STOP between them.
        unseen = was is STOP and self._unseen_since(entered_s, now)
        returning = self._returning(mode, now)
        if unseen and before.demand.armed:
            ledger.arm()  # no frame may have shown it
        elif unseen and before.demand.deadline_s is not None:
            ledger.reinstate(before.demand.deadline_s, before.demand.stopped_by)
        if not returning and not (unseen and mode is before.source):
            blind_s = self.delays.blind_until(mode) - source.left_zero_at
            stale_s = STALE_S[mode] + max(0.0, blind_s)
            recently_zero = now - source.left_zero_at < stale_s  # may still be seen
            source.seen_zero = source.throttle_norm == 0.0 or recently_zero
        leaving = was is STOP and held_s >= self.timing.stop_hold_s
        pending = self.pending
        # Held long enough for the debounce's frames, the position before this move may have
        # armed into its source (at zero throttle): this move is then a handover.
        if (
            pending is not None
            and was is not STOP
            and held_s >= self.timing.stop_hold_s
            and self.sources[pending.mode].throttle_norm == 0.0
        ):
            self.arm_now(now, pending.mode)
        if leaving or pending is not None:  # still within the debounce: it may count
            self.pending = Pending(now, mode)
