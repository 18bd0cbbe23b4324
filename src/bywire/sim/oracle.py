"""The hazard oracle: what the robot's outputs must be, judged from what was done to the robot.

It never asks the controller what it believes: it is told every action and fault the test (or
`bywire verify`) applies, and after every pass of the loop it reads the simulated hardware (the
enable line, the DAC's throttle volts, the e-brake line, the steering pulse, the direction lines
and the vehicle's true speed) and checks the output invariants of `docs/SAFETY.md`:

- H1 **no drive without a deliberate act.** After anything that demands STOP (the switch to STOP,
  a lost or implausible RC link, a remote stop, CAN loss in CAN mode, a second sender, failing
  DAC writes, a watchdog trip), once its deadline has passed, the drive outputs are safe until
  a deliberate arming act: the switch held at STOP for two frame periods and moved to RC or CAN
  with that source's throttle at zero and no fault in force, or a CAN re-enable request while
  the switch is at CAN.
- H2 **bumpless handover.** Once the switch has settled on a source, throttle volts above zero
  mean that source has been seen at zero throttle since the switch moved to it.
- H3 **a watchdog trip is final.** After a trip, until the switch is put to STOP, the enable line
  stays low, the e-brake engaged, the throttle at 0 V and the steering pulse where it was.
- H4 **direction against motion.** With a working speed sensor, the motors are never driven with
  throttle against the direction the robot really moves faster than the standstill threshold.

Where the controller's timing makes the expected level uncertain (a debounce in progress, a
fault just injected) the oracle leans towards allowing: it must never flag a correct robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode

FRAME_S = 0.0077
SETTLE_S = 0.045  # a switch position counts after 3 frames; then one control period
STOP_HOLD_S = 2 * FRAME_S  # the least hold at STOP in which 3 frames can show it
UNSEEN_S = FRAME_S + 0.004  # a position held less than a frame (and its wire time) may be missed
STANDSTILL_MPS = 0.05

# How long after each kind of event the outputs may still drive (detection + frame + period).
DEADLINES_S = {
    "switch_stop": 0.030,
    "rc_link_lost": 0.125,
    "rc_failsafe": 0.030,
    "rc_implausible": 0.030,
    "remote_stop": 0.045,
    "can_lost": 0.150,
    "can_impostor": 0.200,
    "dac_fail": 0.060,
    "watchdog": 0.230,
}


# How long a fault must last before the controller can have noticed it at all: one that ends
# sooner may have passed unseen (a link back before its timeout, a request never sent).
UNNOTICED_S = {
    "rc_link_lost": 0.110,
    "rc_failsafe": 0.010,
    "remote_stop": 0.025,
    "can_lost": 0.125,
    "can_impostor": 0.080,
    "dac_fail": 0.030,
}


RC_BORNE = frozenset({"switch_stop", "rc_implausible", "rc_failsafe"})


@dataclass(slots=True)
class Violation:
    """One broken invariant: which, when, and what the hardware showed."""

    invariant: str
    time_s: float
    detail: str


# How long a source's old value may still be what the controller sees after it changed: one
# command period plus wire time for CAN; none for RC, whose switch and sticks share each frame.
STALE_S = {ControlMode.RC: 0.0, ControlMode.CAN: 0.025}


@dataclass(slots=True)
class _Source:
    throttle_norm: float = 0.0
    seen_zero: bool = True
    left_zero_at: float = -1.0  # when the throttle last went from zero to non-zero


@dataclass(slots=True)
class HazardOracle:
    """Told every action; `observe` after every pass checks H1-H4 on the world's hardware."""

    world: SimWorld
    throttle_channel: int = 0
    violations: list[Violation] = field(default_factory=list)
    checks: int = 0
    switch: ControlMode = ControlMode.STOP
    switch_at: float = 0.0
    armed_ok: bool = False
    drive_allowed_until: float | None = None
    faults: set[str] = field(default_factory=set)
    fault_changed_at: float = -1.0
    sources: dict[ControlMode, _Source] = field(
        default_factory=lambda: {ControlMode.RC: _Source(), ControlMode.CAN: _Source()}
    )
    pending_arm: tuple[float, ControlMode] | None = None
    tripped_at: float | None = None
    held_pulse_s: float | None = None
    sensor_dead: bool = False
    armed_before_stop: bool = False
    source_before_stop: ControlMode = ControlMode.STOP
    began: dict[str, tuple[float, bool]] = field(default_factory=dict)
    left_at: dict[ControlMode, float] = field(default_factory=dict)

    # --- what was done ----------------------------------------------------------------------------

    def stop_event(self, kind: str, now: float) -> None:
        """Something that demands STOP happened at `now` (what IBUS frames carry only counts
        while frames arrive: a lost link has its own, longer deadline)."""
        silenced = {"rc_link_lost"} if kind != "switch_stop" else {"rc_link_lost", "rc_failsafe"}
        if kind in RC_BORNE and self.faults & silenced:
            return
        if self.armed_ok:
            self.armed_ok = False
            self.drive_allowed_until = now + DEADLINES_S[kind]
        elif self.drive_allowed_until is not None:
            self.drive_allowed_until = min(self.drive_allowed_until, now + DEADLINES_S[kind])

    def fault(self, kind: str, active: bool, now: float) -> None:
        """A fault condition begins (and stops the robot) or ends; saying it again changes
        nothing (a remote stop already requested does not arrive again)."""
        if active == (kind in self.faults):
            return
        self.fault_changed_at = now
        if active:
            self.faults.add(kind)
            self.began[kind] = (now, self.armed_ok)
            self.stop_event(kind, now)
            return
        self.faults.discard(kind)
        began_s, armed_before = self.began.pop(kind, (now, False))
        if armed_before and now - began_s < UNNOTICED_S.get(kind, 0.0):
            self.armed_ok, self.drive_allowed_until = True, None  # it may have passed unseen

    def set_switch(self, mode: ControlMode, now: float) -> None:
        if mode is self.switch:
            return  # not a move: the frames do not change
        held_s = now - self.switch_at
        was = self.switch
        self.switch, self.switch_at = mode, now
        if mode is ControlMode.STOP:
            if self.pending_arm is not None:  # cut short: it may have armed meanwhile
                self._arm_now(now, self.pending_arm[1])
                self.pending_arm = None
            self.armed_before_stop, self.source_before_stop = self.armed_ok, was
            self.stop_event("switch_stop", now)
            self.tripped_at = None  # the operator's acknowledgement begins
            return
        self.left_at[was] = now
        source = self.sources[mode]
        # Back to a source within the debounce: the controller may never have left it.
        returning = now - self.left_at.get(mode, -1.0) < SETTLE_S and was is not ControlMode.STOP
        unseen = was is ControlMode.STOP and held_s < UNSEEN_S
        if unseen and self.armed_before_stop:
            self.armed_ok, self.drive_allowed_until = True, None  # no frame may have shown it
        if not returning and not (unseen and mode is self.source_before_stop):
            recently_zero = now - source.left_zero_at < STALE_S[mode]  # may still be seen
            source.seen_zero = source.throttle_norm == 0.0 or recently_zero
        leaving = was is ControlMode.STOP and held_s >= STOP_HOLD_S
        if leaving or self.pending_arm is not None:  # still within the debounce: it may count
            self.pending_arm = (now, mode)

    def set_throttle(self, source: ControlMode, throttle_norm: float, now: float) -> None:
        state = self.sources[source]
        if state.throttle_norm == 0.0 and throttle_norm != 0.0:
            state.left_zero_at = now
        state.throttle_norm = throttle_norm
        if throttle_norm == 0.0:
            state.seen_zero = True
        if self.pending_arm is not None and self.pending_arm[1] is source:
            self.pending_arm = None  # changed within the debounce: whether it armed is timing
            self._arm_now(now, source)

    def re_enable(self, now: float) -> None:
        """A CAN re-enable request (a 0→1 change) was sent."""
        if self.switch is ControlMode.CAN:
            self._arm_now(now, ControlMode.CAN)

    def stall(self, started_s: float, trips_at_s: float) -> None:
        """A write hangs from `started_s` past the watchdog's limit: it trips at `trips_at_s`."""
        self.tripped_at = trips_at_s
        self.held_pulse_s = None
        self.stop_event("watchdog", started_s)

    # --- what the hardware shows -----------------------------------------------------------------

    def observe(self, now: float) -> None:
        """Check every invariant on the hardware as it is at `now`."""
        self.checks += 1
        self._resolve_arming(now)
        world = self.world
        enable = world.gpio["motors_enable"].level
        released = world.gpio["ebrake_release"].level
        volts = world.dac.volts(self.throttle_channel)
        # A failed DAC may hold its last voltage: the enable line is what stops the motors.
        driving = enable or released
        self._h1(now, driving, enable, released, volts)
        self._h2(now, volts if enable else 0.0)
        self._h3(now, enable, released, volts)
        self._h4(now, enable, volts)

    def _resolve_arming(self, now: float) -> None:
        if self.pending_arm is None or now < self.pending_arm[0] + SETTLE_S:
            return
        _, mode = self.pending_arm
        self.pending_arm = None
        if self.switch is mode and self.sources[mode].throttle_norm == 0.0:
            self._arm_now(now, mode)

    def _arm_now(self, now: float, target: ControlMode) -> None:
        """A deliberate act into `target`, unless a fault that must refuse it has been in
        force a while."""
        can_only = {"can_lost", "can_impostor", "remote_stop"}
        blocking = self.faults - (can_only if target is ControlMode.RC else set())
        settled = now - self.fault_changed_at > 0.3
        if not (blocking and settled):
            self.armed_ok, self.drive_allowed_until = True, None

    def _flag(self, invariant: str, now: float, detail: str) -> None:
        self.violations.append(Violation(invariant, now, detail))

    def _h1(self, now: float, driving: bool, enable: bool, released: bool, volts: float) -> None:
        deadline = self.drive_allowed_until
        allowed = (
            self.armed_ok
            or self.pending_arm is not None  # a debounce in progress may arm
            or (deadline is not None and now < deadline)
        )
        if driving and not allowed:
            self._flag(
                "H1", now, f"enable={enable} ebrake_release={released} throttle={volts:.2f} V"
            )

    def _h2(self, now: float, volts: float) -> None:
        mode = self.switch
        if volts <= 0.0 or mode is ControlMode.STOP or now < self.switch_at + SETTLE_S:
            return
        if not self.sources[mode].seen_zero:
            self._flag("H2", now, f"{mode.name} never at zero throttle; throttle={volts:.2f} V")

    def _h3(self, now: float, enable: bool, released: bool, volts: float) -> None:
        if self.tripped_at is None or now < self.tripped_at + 0.010:
            return
        pulse = self.world.pwm.steering.pulse_s
        if self.held_pulse_s is None:
            self.held_pulse_s = pulse
        stuck_dac = "dac_fail" in self.faults
        if enable or released or (volts > 0.0 and not stuck_dac) or pulse != self.held_pulse_s:
            self._flag(
                "H3",
                now,
                f"after the trip: enable={enable} ebrake_release={released} "
                f"throttle={volts:.2f} V pulse={pulse * 1000:.3f} ms",
            )

    def _h4(self, now: float, enable: bool, volts: float) -> None:
        if self.sensor_dead or not enable or volts <= 0.0:
            return
        speed = self.world.vehicle.state.speed_mps
        forward = self.world.gpio["motors_forward"].level
        reverse = self.world.gpio["motors_reverse"].level
        if (reverse and speed > STANDSTILL_MPS) or (forward and speed < -STANDSTILL_MPS):
            direction = "reverse" if reverse else "forward"
            self._flag("H4", now, f"driven {direction} at {speed:.2f} m/s")
