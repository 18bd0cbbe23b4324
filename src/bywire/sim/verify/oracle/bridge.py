"""The ROS 2 bridge's invariants (B1..B3 of `docs/SAFETY.md`), judged in bridge campaigns after
every period of the bridge's link: on the vehicle's true speed and the output lines, on what the
oracle was told (the switch, what is broken), and on the bridge's own outputs (its decision, and
`/diagnostics` as the pure builder makes it from the link's snapshot).

- **B1** With the speed flagged (the robot's reports carry SPEED_SENSOR_FAULT) or unknown (a
  robot without the wheel-speed sensor) while the bridge drives: the throttle it *asks for* is
  at most `BLIND_THROTTLE_NORM` (0: bridge rule 4a), whatever the controller then does with it
  (in CAN mode the controller takes no throttle while the fault is latched, SAFETY row 55: a
  bridge that asks is still wrong, and on a robot without the sensor nothing else holds it);
  the true speed does not grow by more than `GROWTH_MPS` from where it was when the flag
  arrived; and the robot reaches standstill within the bridge's own blind bound
  (`stop_ramp.blind_brake_s`: full brake's stop from the fastest speed its settings know) plus
  `REPORT_LAG_S`.
- **B2** Once the planner's set-points run out (silent or aged out) while the robot rolls, the
  true speed reaches standstill within the bridge's own stated bound from that speed
  (`stop_ramp.stop_bound_s`, one definition for the bridge and its judge) plus `REPORT_LAG_S`;
  and the brake is never let down to the holding brake while the robot still rolls.
- **B3** Every set-point refused at arrival, and every period in which a live planner's
  set-points are not used (the bridge stops although the planner keeps publishing), is
  counted in `/diagnostics` (`commands_refused` grows, and for a refusal at arrival the count
  of its reason, `refused_<reason>`, from the bridge's `setpoint.Tally`), whose inputs status is
  WARN or ERROR, within `bridge_refusals.GRACE_S`.

B1 and B2 are judged only while the bridge drives the robot: enabled, the switch at CAN, the
motors enabled and the spring brake released (a stop of the controller's own is H1..H11's to
judge), and B2 only with the hydraulic brake and the wheel sensor working (without them the
stop is B1's or the controller's).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from bywire.ros2 import stop_ramp
from bywire.ros2.bridge import Activity, Decision
from bywire.ros2.link import Snapshot
from bywire.ros2.setpoint import Refusal
from bywire.ros2.settings import BridgeSettings
from bywire.sim.bridge_refusals import RefusalBooks
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.judge import HazardOracle
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.teleop.frames import SEND_PERIOD_S

BLIND_THROTTLE_NORM = 0.0  # B1: the throttle a bridge may ask for without a trusted speed
GROWTH_MPS = 0.15  # B1: what the true speed may still gain once the flag has arrived
ROLLING_MARGIN_MPS = 0.05  # above the bridge's standstill speed: the robot rolls
REPORT_LAG_S = 2 * SEND_PERIOD_S  # B1, B2: the bridge's bounds are on the speed it is told,
# one report period late; the true speed is judged, and the brake follows a period later


def stop_bound_s(from_mps: float, settings: BridgeSettings) -> float:
    """B2's bound from `from_mps`: the bridge's own (`stop_ramp.stop_bound_s`) plus
    `REPORT_LAG_S`."""
    return stop_ramp.stop_bound_s(from_mps, settings) + REPORT_LAG_S


def blind_bound_s(settings: BridgeSettings) -> float:
    """B1's bound from the flag: the bridge's full brake without a trusted speed
    (`stop_ramp.blind_brake_s`) plus `REPORT_LAG_S`."""
    return stop_ramp.blind_brake_s(settings) + REPORT_LAG_S


@dataclass(slots=True)
class Watch:
    """A stop the bridge owes: since when, from which true speed, by when."""

    since_s: float
    from_mps: float
    deadline_s: float


class BridgeJudge:
    """Checks B1..B3 after every period of the bridge's link; violations go to `oracle`'s."""

    def __init__(
        self, oracle: HazardOracle, settings: BridgeSettings, publishing: Callable[[], bool]
    ) -> None:
        """`publishing`: whether the planner publishes now (at its rate, 10 Hz or more)."""
        self.oracle = oracle
        self.settings = settings
        self.publishing = publishing
        self.flagged: Watch | None = None  # B1
        self.asked_blind = False  # B1: a throttle asked in this flagged episode, flagged once
        self.stopping: Watch | None = None  # B2
        self.brake_norm = 0.0  # the brake the bridge asked for in the period before
        self.activity = Activity.DISENGAGED
        self.refusals = RefusalBooks()  # B3's, one definition with bridge_unshown_drop's

    # --- what the planner offered ------------------------------------------------------------

    def offered(self, at_s: float, refusal: Refusal | None) -> None:
        """The planner offered a set-point at `at_s`; `refusal`: why the link refused it."""
        self.refusals.offered(at_s, refusal)

    # --- one period of the link --------------------------------------------------------------

    def tick(self, decision: Decision, snapshot: Snapshot, now: float) -> None:
        out = Outputs.read(self.oracle.world)
        driving = (
            snapshot.engaged
            and self.oracle.switch is ControlMode.CAN
            and out.enable
            and out.released
        )
        found = [
            self._b1(decision, snapshot, out, driving, now),
            self._b2(decision, out, driving, now),
            self._b3(decision, snapshot, now),
        ]
        self.oracle.violations.extend(v for v in found if v is not None)
        self.brake_norm, self.activity = decision.pedals.brake_norm, decision.activity

    def _rolling(self, out: Outputs) -> bool:
        return abs(out.speed_mps) > self.settings.standstill_speed_mps + ROLLING_MARGIN_MPS

    def _b1(
        self, decision: Decision, snapshot: Snapshot, out: Outputs, driving: bool, now: float
    ) -> Violation | None:
        flagged = bool(snapshot.status.flags & ErrorFlag.SPEED_SENSOR_FAULT)
        fitted = self.oracle.plant.sensors_fitted
        if not ((flagged or not fitted) and driving):
            self.flagged, self.asked_blind = None, False
            return None
        why = "flagged (SPEED_SENSOR_FAULT)" if fitted else "unknown (no wheel-speed sensor)"
        speed = abs(out.speed_mps)
        if self.flagged is None:
            self.flagged = Watch(now, speed, now + blind_bound_s(self.settings))
        watch = self.flagged
        throttle = decision.pedals.throttle_norm
        if throttle > BLIND_THROTTLE_NORM and not self.asked_blind:
            self.asked_blind = True
            detail = (
                f"the speed {why} since {watch.since_s:.3f} s and the bridge driving: it asks"
                f" for throttle {throttle:.3f} (at most {BLIND_THROTTLE_NORM:g}), the robot at"
                f" {speed:.2f} m/s"
            )
            expected = {"bridge_throttle_max_norm": BLIND_THROTTLE_NORM}
            return Violation.of(Invariant.B1, now, detail, **expected)
        if speed > watch.from_mps + GROWTH_MPS:
            self.flagged = None
            limit = watch.from_mps + GROWTH_MPS
            detail = (
                f"the speed {why} since {watch.since_s:.3f} s and the bridge driving:"
                f" true speed {speed:.2f} m/s, up from {watch.from_mps:.2f}"
            )
            return _speed_violation(Invariant.B1, now, detail, out.speed_mps, limit)
        if (
            now > watch.deadline_s
            and self._rolling(out)
            and not self.oracle.plant.hydrobrake_failed
        ):
            self.flagged = None
            detail = (
                f"the speed {why} since {watch.since_s:.3f} s: still rolling at"
                f" {speed:.2f} m/s after {now - watch.since_s:.2f} s"
            )
            limit = self.settings.standstill_speed_mps + ROLLING_MARGIN_MPS
            return _speed_violation(Invariant.B1, now, detail, out.speed_mps, limit)
        return None

    def _b2(self, decision: Decision, out: Outputs, driving: bool, now: float) -> Violation | None:
        plant = self.oracle.plant
        stopping = decision.activity is Activity.STOPPING
        judged = driving and stopping and not (plant.hydrobrake_failed or plant.sensor_dead)
        if not judged or not self._rolling(out):
            self.stopping = None
            return None
        speed = abs(out.speed_mps)
        if self.stopping is None:
            if self.activity is not Activity.DRIVING:
                return None  # not the planner falling silent: disengaged before, or a watch ended
            self.stopping = Watch(now, speed, now + stop_bound_s(speed, self.settings))
            return None
        watch = self.stopping
        hold = self.settings.hold_brake
        limit = self.settings.standstill_speed_mps + ROLLING_MARGIN_MPS
        if decision.pedals.brake_norm <= hold < self.brake_norm:
            self.stopping = None
            detail = (
                f"the stop ramp from {watch.from_mps:.2f} m/s (since {watch.since_s:.3f} s) let"
                f" the brake down to the holding brake {hold:g} with the robot at {speed:.2f} m/s"
            )
            return _speed_violation(Invariant.B2, now, detail, out.speed_mps, limit)
        if now > watch.deadline_s:
            self.stopping = None
            detail = (
                f"the planner's set-points ran out at {watch.since_s:.3f} s at"
                f" {watch.from_mps:.2f} m/s: still rolling at {speed:.2f} m/s after"
                f" {now - watch.since_s:.2f} s (bound {watch.deadline_s - watch.since_s:.2f} s)"
            )
            return _speed_violation(Invariant.B2, now, detail, out.speed_mps, limit)
        return None

    def _b3(self, decision: Decision, snapshot: Snapshot, now: float) -> Violation | None:
        unshown = self.refusals.period(decision.activity, snapshot, self.publishing(), now)
        if unshown is None:
            return None
        detail = (
            f"commands refused or unused (a live planner, the bridge {decision.activity.name})"
            f" but /diagnostics shows commands_refused={unshown.refused}"
            f" ({unshown.required} due; by reason {_counts(unshown.seen_by_reason)}, due"
            f" {_counts(unshown.due_by_reason)}) and its inputs {unshown.level.name}"
        )
        self.refusals.forgive()  # one finding per episode
        return Violation.of(Invariant.B3, now, detail)


def _counts(counts: dict[str, int]) -> str:
    return ", ".join(f"{name.lower()}={n}" for name, n in counts.items() if n) or "none"


def _speed_violation(
    invariant: Invariant, now: float, detail: str, speed_mps: float, limit_mps: float
) -> Violation:
    """A violation expecting the true speed within `limit_mps` of standstill, either way."""
    bound = round(limit_mps, 3)
    expected = {"speed_max_mps": bound} if speed_mps >= 0 else {"speed_min_mps": -bound}
    return Violation.of(invariant, now, detail, **expected)
