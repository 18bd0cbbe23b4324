"""What may delay the controller's seeing or acting on something: frames lost to corruption (its
IBUS frames, the computer's CAN frames), a DAC write that hangs the loop short of a watchdog
trip, and DAC transfers that crawl."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.model import ControlMode
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming


@dataclass(slots=True)
class Delays:
    """The stretches in which frames may be lost, and the loop's hang."""

    timing: OracleTiming
    rc_blind_from: float = -1.0  # IBUS frames may be lost to corruption from then…
    rc_blind_until: float = -1.0  # …until then
    can_blind_until: float = -1.0  # the computer's frames may be dropped until then
    hung_from: float = -1.0  # a write hangs the loop (short of a trip) from then…
    hung_until: float = -1.0  # …until then
    write_lag_s: float = 0.0  # every DAC transfer crawls: each pass may end this much later

    def blind(self, source: ControlMode, from_s: float, until_s: float) -> None:
        """Frames of `source` may be lost from `from_s` until `until_s`."""
        if source is ControlMode.RC:
            if from_s > self.rc_blind_until:
                self.rc_blind_from = from_s  # a new blind stretch, not a longer one
            self.rc_blind_until = max(self.rc_blind_until, until_s)
        else:
            self.can_blind_until = max(self.can_blind_until, until_s)

    def blind_until(self, source: ControlMode) -> float:
        return self.rc_blind_until if source is ControlMode.RC else self.can_blind_until

    def all_may_be_lost(self, frames: int, now: float) -> bool:
        """The next `frames` IBUS frames all go out while frames are being corrupted: a passing
        event they carry (a bounce, an implausible pulse) may never reach the controller at
        all, where a switch's new position only arrives later."""
        last_sent_s = now + frames * self.timing.frame_s
        return self.rc_blind_from <= now and last_sent_s <= self.rc_blind_until

    def hidden(self, switch_at: float, now: float) -> bool:
        """Every frame since the switch moved at `switch_at` may have been lost: the controller
        may never have seen that position (a move to STOP acts on one frame, so a frame sent
        before the corruption began would have shown it)."""
        began_s = switch_at + self.timing.unseen_s
        return self.rc_blind_from < began_s and now <= self.rc_blind_until

    def hang(self, from_s: float, until_s: float) -> None:
        """The loop's next write after `from_s` hangs until `until_s`, short of a trip."""
        self.hung_from, self.hung_until = from_s, until_s

    def past_hang(self, from_s: float, until_s: float) -> float:
        """`until_s`, the end of something the loop must do from `from_s`; if a hang overlaps
        that, one pass after the hang instead (the rest of the hung pass, then one more)."""
        until_s += self.write_lag_s
        if self.hung_from > until_s or self.hung_until < from_s:
            return until_s
        return max(until_s, self.hung_until + 2 * self.timing.control_period_s)
