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
  the switch is at CAN. A re-enable re-arms only what CAN may clear (S8): after a stop that only
  the switch acknowledges (a lost or implausible RC link, failing DAC writes, a watchdog trip),
  it does not count until the switch has been to STOP.
- H2 **bumpless handover.** Once the switch has settled on a source (its debounce's frames
  arrived), throttle volts above zero mean that source has been seen at zero throttle since the
  switch moved to it.
- H3 **a watchdog trip is final.** After a trip, until the switch is put to STOP, the enable line
  stays low, the e-brake engaged, the throttle at 0 V and the steering pulse where it was.
- H4 **direction against motion.** With a working speed sensor, the motors are never driven with
  throttle against the direction the robot really moves faster than the standstill threshold.
- H5 **STOP is the whole STOP.** Whenever H1 wants the drive cut (and it is), the hydraulic brake
  is at full duty and the steering pulse stays where it was when that began (centring at speed
  is a swerve; with a boosted steering, `boost_gain` > 0, the pulse settles onto the held
  set-point, and only the brake is judged).
- H6 **brake beats throttle.** With the motors enabled, throttle volts above zero never come with
  a brake (regenerative volts or hydraulic duty above zero) for longer than a control period.
- H7 **a stop stops.** While the e-brake line is engaged and the robot moves, it slows by at
  least `REQUIRED_DECEL_MPS2` for as long as any brake can work: the spring brake and the
  hydraulic brake unless they failed, and the drive's regenerative brake for the first
  `REGEN_WINDOW_S` of a stop whose cause leaves the drive healthy (category 1). A stop that cuts
  the drive's power without cause throws the last brake away.
- H9 **a handover is bumpless for the steering.** Once a source takes over (the switch settled on
  it, or a re-enable), the steering pulse moves towards that source's steering no faster than
  `REQUIRED_HANDOVER_RATE` (full ranges per second below 1 m/s, falling as 1/speed above) until
  it has reached it (not judged with a boosted steering, whose pulse leads its set-point).
- H8 **the exit path never gives up.** When the controller ends on a failed output (a dead line),
  every other output is left at its safe level: enable low, e-brake engaged, hydraulic brake at
  full duty, throttle at 0 V.

H1 allows a controlled stop (category 1, `bywire.control.stop`): the enable line may stay high,
with the throttle at 0 V and the regenerative brake applied, for at most `CONTROLLED_STOP_LIMIT_S`
after the stop began and never once the robot has stood still for `STANDSTILL_GRACE_S` (with a
wheel sensor that never died), unless a cause that makes the drive suspect is in force (failing
or crawling DAC writes, a watchdog trip): then the enable line must be low. These figures are the
requirements' (`docs/SAFETY.md`), not the configuration's: the robot file's own bound is held
inside them at load.

Each violation carries what the hardware should have shown (`Violation.expected`, conditions of
a scenario's expectation), so `bywire verify` can write it as a scenario that fails there.

Where the controller's timing makes the expected level uncertain (a debounce in progress, a
fault just injected) the oracle leans towards allowing: it must never flag a correct robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from bywire.config.consistency import CONTROL_TASKS
from bywire.config.model import RobotConfig
from bywire.control.steering import SteeringConfig
from bywire.control.stop import (
    MAX_CONTROLLED_STOP_S,
    MIN_CONTROLLED_STOP_S,
    STANDSTILL_LIMIT_MPS,
)
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, MovementCommand

CONTROLLED_STOP_LIMIT_S = MAX_CONTROLLED_STOP_S
"""The longest a controlled stop may keep the drive powered (the requirement; a robot file's
`[stop] controlled_max_s` is held within it at load)."""
REGEN_WINDOW_S = MIN_CONTROLLED_STOP_S
"""How long a controlled stop surely keeps its regenerative brake (unless standing still)."""
STANDSTILL_GRACE_S = 0.05
"""Standing still this long, with a wheel sensor that tells the truth, ends a controlled stop."""
REQUIRED_DECEL_MPS2 = 1.0
"""The least deceleration of a stop while any brake works (the simulated robot's weakest brake,
regeneration alone with rolling drag, gives 1.65 m/s²)."""
BRAKE_REACT_S = 0.05
"""How long a brake may take to bite once applied."""
REQUIRED_HANDOVER_RATE = 2.0
"""How fast a handover may move the steering below 1 m/s (the most a robot file may set)."""
SLOW_TRANSFER_S = 0.020
"""A DAC transfer slower than this is no ordinary one (the robot file's budget is at most this):
STOP, category 0. Transfers of 2 ms are ordinary and must never stop the robot."""
POWER_OFF_KINDS = frozenset({"dac_fail", "dac_slow", "watchdog"})
"""Stops whose cause makes the drive suspect: category 0, the enable line low."""
CAN_PERIOD_S = 0.020  # the simulated computer's movement commands
CAN_STALE_S = CAN_PERIOD_S + 0.005  # a CAN value may still be seen a period (and wire time) late


@dataclass(frozen=True, slots=True)
class ServoPulses:
    """The servo's calibration (a physical fact of the robot, not a deadline): a steering
    norm's pulse, and the pulses from centre to either end."""

    center_s: float = 0.0015
    half_span_s: float = 0.0005
    reverse: bool = False

    @classmethod
    def of(cls, servo: SteeringConfig) -> ServoPulses:
        half_s = min(
            servo.max_pulse_s - servo.center_pulse_s, servo.center_pulse_s - servo.min_pulse_s
        )
        return cls(servo.center_pulse_s, half_s, servo.reverse)

    def pulse_s(self, steering_norm: float) -> float:
        norm = -steering_norm if self.reverse else steering_norm
        return self.center_s + norm * self.half_span_s


@dataclass(frozen=True, slots=True)
class OracleTiming:
    """How long the controller may take for each thing, from the robot's own numbers.

    Every allowance is the configured timeout (or debounce) plus the frame, command period and
    control periods in which the controller may notice it and act: the defaults reproduce the
    figures `docs/SAFETY.md` gives, and a robot file with other timeouts gets other deadlines.
    """

    frame_s: float = 0.0077  # the RC receiver's frame period
    debounce_frames: int = 3
    rc_timeout_s: float = 0.100
    can_timeout_s: float = 0.100
    watchdog_s: float = 0.200
    control_period_s: float = 0.010
    driving_period_s: float = 0.010  # the task that writes the DAC
    standstill_mps: float = 0.05
    # The fastest a wheel sensor can die unnoticed: its drop to 0 m/s is then within the speed
    # check's step tolerance plus what braking explains in a pass (docs/SAFETY.md row 27).
    unnoticed_death_mps: float = 0.45
    steering_boosted: bool = False  # the pulse settles onto a held set-point (boost_gain > 0)
    servo: ServoPulses = field(default_factory=ServoPulses)

    @classmethod
    def for_robot(cls, robot: RobotConfig) -> OracleTiming:
        slowest_hz = min(robot.tasks.rate_hz(name) for name in CONTROL_TASKS)
        return cls(
            frame_s=robot.sim.rc_frame_period_s,
            debounce_frames=robot.supervisor.debounce_frames,
            rc_timeout_s=robot.timeouts.rc_timeout_s,
            can_timeout_s=robot.timeouts.can_timeout_s(MovementCommand.__name__),
            watchdog_s=robot.timeouts.watchdog_s,
            control_period_s=1.0 / slowest_hz,
            driving_period_s=1.0 / robot.tasks.rate_hz("driving"),
            standstill_mps=robot.interlocks.standstill_speed_mps,
            unnoticed_death_mps=robot.interlocks.speed_step_tolerance_mps
            + robot.interlocks.speed_max_change_mps2 / slowest_hz,
            steering_boosted=robot.steering.servo.boost_gain > 0.0,
            servo=ServoPulses.of(robot.steering.servo),
        )

    @property
    def settle_s(self) -> float:
        """A switch position counts after the debounce's frames; then one control period (and
        slack for the frame's wire time)."""
        return self.debounce_frames * self.frame_s + self.control_period_s + 0.012

    @property
    def stop_hold_s(self) -> float:
        """The least hold at STOP in which the debounce's frames can show it."""
        return (self.debounce_frames - 1) * self.frame_s

    @property
    def unseen_s(self) -> float:
        """A position held less than a frame (and its wire time) may be missed."""
        return self.frame_s + 0.004

    def deadline_s(self, kind: str) -> float:
        """How long after an event of `kind` the outputs may still drive: detection, then a
        frame or command period, then the control periods that act on it."""
        frame, period = self.frame_s, self.control_period_s
        return {
            "switch_stop": frame + 2 * period + 0.0023,
            "rc_failsafe": frame + 2 * period + 0.0023,
            "rc_implausible": frame + 2 * period + 0.0023,
            "rc_link_lost": self.rc_timeout_s + frame + period + 0.0073,
            "remote_stop": CAN_PERIOD_S + 2 * period + 0.005,
            "can_lost": self.can_timeout_s + 2 * CAN_PERIOD_S + period,
            "can_unplugged": self.can_timeout_s + 2 * CAN_PERIOD_S + period,
            "can_impostor": 0.200,  # its frames are judged over a window of 16 counters
            # Three failed writes (the leaky count), a period to act, and two of margin.
            "dac_fail": 6 * self.driving_period_s,
            # The next transfer (within a driving period) crawls; enable low as it returns.
            "dac_slow": self.driving_period_s + 2 * period + 0.005,
            "watchdog": self.watchdog_s + 3 * period,
        }[kind]

    def unnoticed_s(self, kind: str) -> float:
        """How long a fault must last before the controller can have noticed it at all: one
        that ends sooner may have passed unseen (a link back before its timeout)."""
        return {
            "rc_link_lost": self.rc_timeout_s + 0.010,
            "rc_failsafe": 0.010,
            "remote_stop": 0.025,
            "can_lost": self.can_timeout_s + 0.025,
            "can_unplugged": self.can_timeout_s + 0.025,
            "can_impostor": 0.080,
            "dac_fail": 3 * self.driving_period_s,
        }.get(kind, 0.0)


RC_BORNE = frozenset({"switch_stop", "rc_implausible", "rc_failsafe"})
"""Events the IBUS frames carry: corrupted frames may delay them (`rc_blind_until`)."""
CAN_SILENT = frozenset({"can_lost", "can_unplugged"})
"""Faults in which nothing the computer sends arrives."""
CAN_ONLY = frozenset({*CAN_SILENT, "can_impostor", "remote_stop"})
"""Faults that stop CAN mode and refuse arming into CAN, never RC."""
SWITCH_ONLY = frozenset({"rc_link_lost", "rc_failsafe", "dac_fail", "dac_slow"})
"""Faults whose latched cause only the operator's switch clears, never a CAN re-enable (S8);
implausible frames (`stop_event`) and the watchdog's trip (`HazardOracle.stall`) are such too,
and so is a second sender (CAN_UNTRUSTED) once it has surely latched (`_impostor_latched_from`)."""
DAC_LATCH_WRITES = 20
"""A DAC failing for this many of the driving task's periods has certainly latched DAC_FAULT:
every other write failing trips the leaky count after eight writes; the rest is margin."""


INVARIANTS = ("H1", "H2", "H3", "H4", "H5", "H6", "H7", "H8", "H9")
SAFE_LEVELS: dict[str, dict[str, Any]] = {
    "H1": {"ebrake_engaged": True, "throttle_volts_max": 0.0},
    "H2": {"throttle_volts_max": 0.0},
    "H3": {"motors_enabled": False, "ebrake_engaged": True, "throttle_volts_max": 0.0},
    "H4": {"throttle_volts_max": 0.0},
    "H5": {"hydrobrake_duty_min": 1.0},
    "H6": {"throttle_volts_max": 0.0},
    "H7": {"ebrake_engaged": True},
    "H9": {},
    "H8": {
        "motors_enabled": False,
        "ebrake_engaged": True,
        "hydrobrake_duty_min": 1.0,
        "throttle_volts_max": 0.0,
    },
}
"""What the hardware should show where each invariant broke (a steering pulse held since the
stop is added where that is what broke): the conditions of a scenario's expectation."""
FULL_DUTY = 1.0


@dataclass(slots=True)
class Violation:
    """One broken invariant: which, when, what the hardware showed and should have shown."""

    invariant: str
    time_s: float
    detail: str
    expected: dict[str, Any] = field(default_factory=dict)


# How long a source's old value may still be what the controller sees after it changed: one
# command period plus wire time for CAN; none for RC, whose switch and sticks share each frame.
STALE_S = {ControlMode.RC: 0.0, ControlMode.CAN: CAN_STALE_S}


@dataclass(frozen=True, slots=True)
class _Demand:
    """What H1 allowed: armed, until when the outputs may still drive, and what set that."""

    armed_ok: bool
    drive_allowed_until: float | None
    stopped_by: frozenset[str]


@dataclass(frozen=True, slots=True)
class _PassingStop:
    """A stop demanded by frames still to be sent (implausible ones), undone if corruption that
    begins before the first of them goes out may take them all, and nothing else moved H1."""

    at_s: float
    last_sent_s: float
    before: _Demand
    after: _Demand


@dataclass(slots=True)
class _SteeringHold:
    """A steering pulse that must stay where it was when the hold began (H3, H5)."""

    pulse_s: float | None = None
    from_s: float = 0.0

    def release(self) -> None:
        self.pulse_s = None

    def moved(self, pulse_s: float, now: float) -> bool:
        """Whether `pulse_s` left the held pulse (the first reading begins the hold)."""
        if self.pulse_s is None:
            self.pulse_s, self.from_s = pulse_s, now
        return pulse_s != self.pulse_s


@dataclass(slots=True)
class _Blend:
    """A source taking over: its steering is judged from `from_s` until the pulse reaches it."""

    source: ControlMode
    from_s: float
    last: tuple[float, float] | None = None  # (time, pulse) at the previous pass


@dataclass(slots=True)
class _Source:
    steering_norm: float = 0.0
    throttle_norm: float = 0.0
    seen_zero: bool = True
    left_zero_at: float = -1.0  # when the throttle last went from zero to non-zero


@dataclass(slots=True)
class HazardOracle:
    """Told every action; `observe` after every pass checks H1-H8 on the world's hardware."""

    world: SimWorld
    throttle_channel: int = 0
    regen_channel: int = 1
    timing: OracleTiming = field(default_factory=OracleTiming)
    violations: list[Violation] = field(default_factory=list)
    checks: int = 0
    switch: ControlMode = ControlMode.STOP
    switch_at: float = 0.0
    switch_shown_s: float = 0.0  # from when frames may show the switch's position (`_h2`)
    stop_since: float = 0.0  # the switch's hold at STOP began (a glimpse away does not end it)
    chatter_until: float = -1.0  # a bouncing switch's frames read STOP every other one until then
    passing_stop: _PassingStop | None = None  # the latest implausible frames' demand
    dac_every_other: bool = False  # the failing DAC NAKs every other write: slower to latch
    armed_ok: bool = False
    drive_allowed_until: float | None = None
    stopped_by: set[str] = field(default_factory=set)  # what set `drive_allowed_until`
    faults: set[str] = field(default_factory=set)
    fault_changed_at: float = -1.0
    sources: dict[ControlMode, _Source] = field(
        default_factory=lambda: {ControlMode.RC: _Source(), ControlMode.CAN: _Source()}
    )
    pending_arm: tuple[float, ControlMode] | None = None
    tripped_at: float | None = None
    trip_hold: _SteeringHold = field(default_factory=_SteeringHold)  # a watchdog trip's (H3)
    stop_hold: _SteeringHold = field(default_factory=_SteeringHold)  # STOP's (H5)
    sensor_dead: bool = False  # the wheel-speed sensor reads 0 m/s whatever the robot does…
    died_at_mps: float = 0.0  # …since it died at this speed, unnoticed if slow enough (`_h4`)…
    brake_failed: bool = False  # …and the hydraulic brake builds no pressure: H4 is off (`_h4`)
    impostor_met_drive: bool = False  # the motors were enabled when a second sender began
    armed_before_stop: bool = False
    # A stop already on its way when the switch went to STOP: its deadline and what set it.
    deadline_before_stop: float | None = None
    stopped_by_before_stop: frozenset[str] = frozenset()
    source_before_stop: ControlMode = ControlMode.STOP
    began: dict[str, tuple[float, bool]] = field(default_factory=dict)
    left_at: dict[ControlMode, float] = field(default_factory=dict)
    rc_borne_at: float = -1.0  # when an event the IBUS frames carry last happened
    dac_back_at: float = -1.0  # when DAC writes last began to succeed again
    rc_blind_from: float = -1.0  # IBUS frames may be lost to corruption from then…
    rc_blind_until: float = -1.0  # …until then
    can_blind_until: float = -1.0  # the computer's frames may be dropped until then
    # What only the switch may clear, and from when it is latched for sure (`_owed`).
    owed_to_switch: dict[str, float] = field(default_factory=dict)
    dac_writes_from: float = -1.0  # the loop writes the DAC (no watchdog trip holds the gate)
    hung_from: float = -1.0  # a write hangs the loop (short of a trip) from then…
    hung_until: float = -1.0  # …until then (`hang`)
    brake_with_throttle_at: float | None = None  # since when H6's combination shows
    ebrake_failed: bool = False  # the spring brake does not engage (undetectable: row 6)
    sensor_ever_dead: bool = False  # the wheel sensor died once: its standstill may not count
    demand_since: float | None = None  # H1 has demanded the stop since then (its deadline)
    standstill_since: float | None = None  # the robot stands still since then, in that stop
    rolled_in_stop: bool = False  # the robot clearly moved in that stop: its sensor read motion
    power_off_from: float | None = None  # a cause that makes the drive suspect acts by then
    braking_from: tuple[float, float] | None = None  # H7: the e-brake engaged then, at that speed
    braking_credit_s: float = 0.0  # H7: how long since then some brake could work
    braking_seen_s: float = 0.0  # H7: when the credit was last counted
    dead_lines: set[str] = field(default_factory=set)  # outputs whose writes fail (H8)
    write_lag_s: float = 0.0  # every DAC transfer crawls: each pass may end this much later
    blend: _Blend | None = None  # a source taking over, judged by H9

    # --- what was done ----------------------------------------------------------------------------

    def stop_event(self, kind: str, now: float) -> None:
        """Something that demands STOP happened at `now` (what IBUS frames carry only counts
        while frames arrive: a lost link has its own, longer deadline)."""
        silenced = {"rc_link_lost"} if kind != "switch_stop" else {"rc_link_lost", "rc_failsafe"}
        if kind in RC_BORNE and self.faults & silenced:
            return
        if kind == "rc_implausible" and now > self.rc_blind_until:
            self.owed_to_switch[kind] = now + self.timing.deadline_s(kind)
        # Frames being corrupted may hide the event until they are over.
        blind_until = self.rc_blind_until if kind in RC_BORNE else now
        deadline = max(now, blind_until) + self.timing.deadline_s(kind)
        deadline = self._past_hang(now, deadline)
        if kind in RC_BORNE:
            self.rc_borne_at = now
        if kind in POWER_OFF_KINDS and (
            self.power_off_from is None or deadline < self.power_off_from
        ):
            self.power_off_from = deadline
        if self.armed_ok:
            self.armed_ok = False
            self.drive_allowed_until = deadline
            self.stopped_by = {kind}
        elif self.drive_allowed_until is not None:
            self.drive_allowed_until = min(self.drive_allowed_until, deadline)
            self.stopped_by.add(kind)

    def chatter(self, frames: int, now: float) -> None:
        """The mode switch bounces: of the next `frames` frames every other one reads STOP."""
        self.chatter_until = now + (frames + 1) * self.timing.frame_s  # and the one in flight
        if not self._all_may_be_lost(frames, now):
            # The last of them reads STOP: an even count starts with a frame at the switch's own
            # position, so the first STOP goes out a frame later (a 19.6 ms frame showed it).
            first_stop_s = now + self.timing.frame_s * (frames % 2 == 0)
            self.stop_event("switch_stop", first_stop_s)

    def implausible(self, frames: int, now: float) -> None:
        """The next `frames` frames carry a pulse no stick gives."""
        if self._all_may_be_lost(frames, now):
            return
        before = self._demand()
        self.stop_event("rc_implausible", now)
        last_sent_s = now + frames * self.timing.frame_s
        self.passing_stop = _PassingStop(now, last_sent_s, before, self._demand())

    def _demand(self) -> _Demand:
        return _Demand(self.armed_ok, self.drive_allowed_until, frozenset(self.stopped_by))

    def _undo_passing_stop(self, from_s: float, until_s: float) -> None:
        """Corruption from `from_s` to `until_s` may take every frame of the passing stop."""
        passing, self.passing_stop = self.passing_stop, None
        if passing is None:
            return
        first_unsent = from_s <= passing.at_s + self.timing.frame_s
        if first_unsent and passing.last_sent_s <= until_s and self._demand() == passing.after:
            before = passing.before
            self.armed_ok, self.drive_allowed_until = before.armed_ok, before.drive_allowed_until
            self.stopped_by = set(before.stopped_by)

    def _all_may_be_lost(self, frames: int, now: float) -> bool:
        """The next `frames` frames all go out while frames are being corrupted: a passing event
        they carry (a bounce, an implausible pulse) may never reach the controller at all, where
        a switch's new position only arrives later."""
        last_sent_s = now + frames * self.timing.frame_s
        return self.rc_blind_from <= now and last_sent_s <= self.rc_blind_until

    def dac_failing(self, now: float, *, every_other: bool) -> None:
        """The DAC NAKs every write, or every other one (which latches later: the leaky count
        reaches its limit at the fourth failure, where failing pairs reach it at the second)."""
        if "dac_fail" not in self.faults:
            self.dac_every_other = every_other
        else:
            self.dac_every_other |= every_other  # a failure under way: the later latch counts
        self.fault("dac_fail", True, now)

    def _unnoticed_s(self, kind: str) -> float:
        if kind == "dac_fail" and self.dac_every_other:
            # four failing writes, each a driving period apart, and a period for the first
            return 5 * self.timing.driving_period_s
        return self.timing.unnoticed_s(kind)

    def fault(self, kind: str, active: bool, now: float) -> None:
        """A fault condition begins (and stops the robot) or ends; saying it again changes
        nothing (a remote stop already requested does not arrive again)."""
        if active == (kind in self.faults):
            return
        self.fault_changed_at = now
        if kind == "rc_link_lost":
            self._link_hides_switch(active, now)
        if active:
            if kind == "can_impostor":
                # Driving, not stopping: a controlled stop keeps the enable line high too, but
                # the e-brake engaged says STOP.
                gpio = self.world.gpio
                self.impostor_met_drive = (
                    gpio["motors_enable"].level and gpio["ebrake_release"].level
                )
            self.faults.add(kind)
            self.began[kind] = (now, self.armed_ok)
            self.stop_event(kind, now)
            unseen = now - self.rc_borne_at < self.timing.unseen_s
            if kind == "rc_link_lost" and unseen and self.drive_allowed_until is not None:
                # No frame may have carried what the link said just before it died: only the
                # link's own timeout stops the robot then.
                lost_s = now + self.timing.deadline_s(kind)
                self.drive_allowed_until = max(self.drive_allowed_until, lost_s)
            return
        self.faults.discard(kind)
        if kind == "dac_fail":
            self.dac_back_at = now
        latched_s = self._latched_from(kind)
        if latched_s is not None and latched_s < now:
            self.owed_to_switch[kind] = latched_s
        began_s, armed_before = self.began.pop(kind, (now, False))
        if armed_before and now - began_s < self._unnoticed_s(kind):
            self.armed_ok, self.drive_allowed_until = True, None  # it may have passed unseen

    def _link_hides_switch(self, lost: bool, now: float) -> None:
        """A link lost before the debounce's frames showed the switch's last move hides the
        move until the link is back (the controller rightly stays where it was)."""
        if lost and now < self.switch_shown_s + self.timing.settle_s:
            self.switch_shown_s = float("inf")
        elif not lost and self.switch_shown_s == float("inf"):
            self.switch_shown_s = now

    def blind(self, source: ControlMode, from_s: float, until_s: float) -> None:
        """Frames of `source` may be lost (corrupted, garbled) from `from_s` until `until_s`:
        what they carry may reach the controller that much later, or never."""
        if source is ControlMode.RC:
            # Implausible frames not yet sent when the corruption began may never be seen.
            if self.owed_to_switch.get("rc_implausible", -1.0) >= from_s:
                del self.owed_to_switch["rc_implausible"]
            self._undo_passing_stop(from_s, until_s)
            if from_s > self.rc_blind_until:
                self.rc_blind_from = from_s  # a new blind stretch, not a longer one
            self.rc_blind_until = max(self.rc_blind_until, until_s)
        else:
            self.can_blind_until = max(self.can_blind_until, until_s)

    def _blind_until(self, source: ControlMode) -> float:
        return self.rc_blind_until if source is ControlMode.RC else self.can_blind_until

    def set_switch(self, mode: ControlMode, now: float) -> None:
        """The mode switch moved to `mode` (a source it settles on takes over: H9; back to one
        within the debounce, the controller may never have left it)."""
        if mode is not self.switch and mode is not ControlMode.STOP:
            returning = (
                self.switch is not ControlMode.STOP
                and now - self.left_at.get(mode, -1.0) < self.timing.settle_s
            )
            self.blend = None
            if not returning:
                self._taking_over(mode, now)
        self._move_switch(mode, now)

    def _move_switch(self, mode: ControlMode, now: float) -> None:
        if mode is self.switch:
            return  # not a move: the frames do not change
        was, entered_s = self.switch, self.switch_at
        held_s = now - (self.stop_since if was is ControlMode.STOP else entered_s)
        self.switch, self.switch_at = mode, now
        self.switch_shown_s = float("inf") if "rc_link_lost" in self.faults else now
        self.left_at[was] = now  # via STOP too: a glimpse of STOP may have gone unseen
        if was is ControlMode.STOP:
            # Held at STOP, the switch cleared whatever was over (leaning to allowing: even a
            # glimpse); what is still in force stays latched, and `_owed` finds it by its start.
            self.owed_to_switch.clear()
        if mode is ControlMode.STOP:
            # Back at STOP after a glimpse away that no frame may have shown: still one hold.
            glimpse = held_s < self.timing.unseen_s and self.left_at.get(mode) == entered_s
            if not glimpse:
                # Among a bouncing switch's frames, the one just before this move may have read
                # STOP too: the controller's run of frames at STOP may start a frame earlier.
                bouncing = now <= self.chatter_until
                self.stop_since = now - self.timing.frame_s if bouncing else now
            if self.tripped_at is not None:  # the gate opens once the STOP is acknowledged
                self.dac_writes_from = now + self.timing.settle_s
            if self.pending_arm is not None:  # cut short: it may have armed meanwhile
                self._arm_now(now, self.pending_arm[1])
                self.pending_arm = None
            self.armed_before_stop, self.source_before_stop = self.armed_ok, was
            self.deadline_before_stop = self.drive_allowed_until
            self.stopped_by_before_stop = frozenset(self.stopped_by)
            self.stop_event("switch_stop", now)
            self.tripped_at = None  # the operator's acknowledgement begins
            return
        if was is ControlMode.CAN and mode is ControlMode.RC and self._can_stop_pending(now):
            # Handed over before the controller could have acted on a CAN-bound fault: RC
            # drives on (CAN-bound causes never block RC).
            self.armed_ok, self.drive_allowed_until = True, None
        source = self.sources[mode]
        # Back to a source within the debounce: the controller may never have left it.
        since_left_s = now - self.left_at.get(mode, -1.0)
        returning = since_left_s < self.timing.settle_s and was is not ControlMode.STOP
        # Whether any frame showed STOP is judged on this stretch at STOP alone: a glimpse away
        # joins two stretches into one hold (above), but no frame read STOP between them.
        stretch_s = now - entered_s
        unseen = was is ControlMode.STOP and (stretch_s < self.timing.unseen_s or self._hidden(now))
        if unseen and self.armed_before_stop:
            self.armed_ok, self.drive_allowed_until = True, None  # no frame may have shown it
        elif unseen and self.deadline_before_stop is not None:
            # A stop already on its way keeps its own deadline: the glimpse did not bring it on.
            self.drive_allowed_until = self.deadline_before_stop
            self.stopped_by = set(self.stopped_by_before_stop)
        if not returning and not (unseen and mode is self.source_before_stop):
            stale_s = STALE_S[mode] + max(0.0, self._blind_until(mode) - source.left_zero_at)
            recently_zero = now - source.left_zero_at < stale_s  # may still be seen
            source.seen_zero = source.throttle_norm == 0.0 or recently_zero
        leaving = was is ControlMode.STOP and held_s >= self.timing.stop_hold_s
        pending = self.pending_arm
        # Held long enough for the debounce's frames, the position before this move may have
        # armed into its source (at zero throttle): this move is then a handover.
        may_have_armed = (
            pending is not None
            and was is not ControlMode.STOP
            and held_s >= self.timing.stop_hold_s
            and self.sources[pending[1]].throttle_norm == 0.0
        )
        if may_have_armed and pending is not None:
            self._arm_now(now, pending[1])
        if leaving or pending is not None:  # still within the debounce: it may count
            self.pending_arm = (now, mode)

    def set_steering(self, source: ControlMode, steering_norm: float, now: float) -> None:
        """A source's steering: a new one while it takes over ends H9's judgement (a command
        moves at the ordinary rate)."""
        self.sources[source].steering_norm = steering_norm
        if self.blend is not None and self.blend.source is source:
            self.blend = None

    def _taking_over(self, source: ControlMode, now: float) -> None:
        self.blend = _Blend(source, self._past_hang(now, now + self.timing.settle_s))

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

    def _hidden(self, now: float) -> bool:
        """Every frame since the switch last moved may have been lost: the controller may
        never have seen that position (a move to STOP acts on one frame, so a frame sent
        before the corruption began would have shown it)."""
        began_s = self.switch_at + self.timing.unseen_s
        return self.rc_blind_from < began_s and now <= self.rc_blind_until

    def _can_stop_pending(self, now: float) -> bool:
        """Only CAN-bound faults demand STOP, and the controller may not have acted yet."""
        deadline = self.drive_allowed_until
        return deadline is not None and now < deadline and self.stopped_by <= CAN_ONLY

    def re_enable(self, now: float) -> None:
        if self.switch is ControlMode.CAN:
            self._taking_over(ControlMode.CAN, now)
        """A CAN re-enable request (a 0→1 change) was sent: it arms if the controller may see
        the switch at CAN (there, or moved on to RC less than a debounce ago: a move counts
        after its frames; the arming is then a handover) and nothing that the switch alone may
        clear is latched. A move to STOP has its own deadline, which an arming cannot lift."""
        left_can_s = now - self.left_at.get(ControlMode.CAN, -1.0)
        leaving = self.switch is ControlMode.RC and left_can_s < self.timing.settle_s
        if (self.switch is ControlMode.CAN or leaving) and not self._owed(now):
            self._arm_now(now, ControlMode.CAN)

    def _latched_from(self, kind: str) -> float | None:
        """From when the fault `kind`, if it lasts, has latched its cause whatever the
        controller's timing (None: not one that only the switch clears, or never for sure)."""
        if kind == "can_impostor" and kind in self.began:
            return self._impostor_latched_from()
        if kind not in SWITCH_ONLY or kind not in self.began:
            return None
        began_s = self.began[kind][0]
        if kind == "dac_fail":  # counted only while the loop's writes reach the DAC
            latch_s = DAC_LATCH_WRITES * self.timing.driving_period_s
            return max(began_s, self.dac_writes_from) + latch_s
        if kind == "rc_failsafe":  # carried by frames: none while lost, late while corrupted
            if "rc_link_lost" in self.faults:
                return None
            began_s = max(began_s, self.rc_blind_until)
        return began_s + self.timing.deadline_s(kind)

    def _impostor_latched_from(self) -> float | None:
        """A second sender latches CAN_UNTRUSTED for sure when it began while the robot drove
        in CAN mode (the switch at CAN, the motors enabled: being allowed to drive is not
        enough, a glimpse of STOP may have left it standing) and nothing else has stopped it
        since: each of its frames takes the real computer's next counter, so every real frame
        after it is a repeat, and three repeats among sixteen frames distrust the id while the
        mode is still CAN. (Begun at STOP, the cause never latches; with the computer silent,
        nothing repeats; with another stop first, the robot may have left CAN mode before the
        id was distrusted.)"""
        began_s, armed = self.began["can_impostor"]
        if not (armed and self.impostor_met_drive) or self.stopped_by != {"can_impostor"}:
            return None
        latched_s = began_s + self.timing.deadline_s("can_impostor")
        return self._past_hang(began_s, latched_s)

    def _owed(self, now: float) -> set[str]:
        """What only the switch may clear now: latched for sure since the switch's last visit
        to STOP, whether over or still in force."""
        owed = {kind for kind, since_s in self.owed_to_switch.items() if since_s < now}
        for kind in self.faults:
            latched_s = self._latched_from(kind)
            if latched_s is not None and latched_s < now:
                owed.add(kind)
        return owed

    def __post_init__(self) -> None:
        # A robot without the sensors (a Linux robot file today) is judged as one whose wheel
        # sensor died at power-up: the no-sensor rule must hold it, from standstill on.
        self.sensor_dead = not self.world.sensors_fitted
        self.sensor_ever_dead = self.sensor_dead

    def sensor_dies(self) -> None:
        """The wheel-speed sensor reads 0 m/s from now on, whatever the robot does (a sensor
        that is not fitted has nothing to lose)."""
        if self.world.sensors_fitted:
            self.sensor_dead, self.died_at_mps = True, abs(self.world.vehicle.state.speed_mps)
            self.sensor_ever_dead = True

    def sensor_restored(self) -> None:
        self.sensor_dead = not self.world.sensors_fitted

    def hang(self, from_s: float, until_s: float) -> None:
        """The loop's next write after `from_s` hangs until `until_s`, too short to trip the
        watchdog: whatever the loop had still to act on waits until it runs again."""
        self.hung_from, self.hung_until = from_s, until_s
        deadline = self.drive_allowed_until
        if deadline is not None:
            self.drive_allowed_until = self._past_hang(-1.0, deadline)

    def _past_hang(self, from_s: float, until_s: float) -> float:
        """`until_s`, the end of something the loop must do from `from_s`; if a hang overlaps
        that, one pass after the hang instead (the rest of the hung pass, then one more)."""
        until_s += self.write_lag_s
        if self.hung_from > until_s or self.hung_until < from_s:
            return until_s
        return max(until_s, self.hung_until + 2 * self.timing.control_period_s)

    def stall(self, started_s: float, trips_at_s: float) -> None:
        """A write hangs from `started_s` past the watchdog's limit: it trips at `trips_at_s`.
        With the switch already at STOP the trip is acknowledged as it happens (S2): H3 has
        nothing to hold, and leaving STOP is an arming like any other."""
        if self.switch is not ControlMode.STOP:
            self.tripped_at = trips_at_s
            self.trip_hold.release()
            self.owed_to_switch["watchdog"] = trips_at_s
            self.dac_writes_from = float("inf")  # the gate refuses them until STOP
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
        allowed = self._h1(now, enable, released, volts)
        self._h2(now, volts if enable else 0.0)
        self._h3(now, enable, released, volts)
        self._h4(now, enable, volts)
        self._h5(now, cut=not (allowed or released))
        self._h6(now, enable, volts)
        self._h7(now, released)
        self._h9(now, released)

    def _resolve_arming(self, now: float) -> None:
        if self.pending_arm is None or now < self.pending_arm[0] + self.timing.settle_s:
            return
        _, mode = self.pending_arm
        self.pending_arm = None
        if self.switch is mode and self.sources[mode].throttle_norm == 0.0:
            self._arm_now(now, mode)

    def _arm_now(self, now: float, target: ControlMode) -> None:
        """A deliberate act into `target`, unless a fault that must refuse it has been in
        force a while."""
        blocking = self.faults - (CAN_ONLY if target is ControlMode.RC else set())
        settled = now - self.fault_changed_at > 0.3
        if not (blocking and settled):
            self.armed_ok, self.drive_allowed_until = True, None

    def _flag(self, invariant: str, now: float, detail: str, **expected: float) -> None:
        wanted = {**SAFE_LEVELS[invariant], **expected}
        self.violations.append(Violation(invariant, now, detail, wanted))

    def _drive_allowed(self, now: float) -> bool:
        """H1: may the drive outputs drive now? Armed, a debounce in progress that may arm, or
        a stop whose deadline has not passed."""
        deadline = self.drive_allowed_until
        return (
            self.armed_ok
            or self.pending_arm is not None
            or (deadline is not None and now < deadline)
        )

    def _h1(self, now: float, enable: bool, released: bool, volts: float) -> bool:
        """Flags driving that is not allowed; returns whether it is. In a stop the enable line
        may stay high only as a controlled stop's (`_controlled`)."""
        allowed = self._drive_allowed(now)
        if allowed:
            self.demand_since = self.standstill_since = None
            self.rolled_in_stop = False
            if self.armed_ok:  # re-armed: what a category 0 cause demanded is over
                self.power_off_from = None
            return True
        if self.demand_since is None:
            self.demand_since = now
        speed = abs(self.world.vehicle.state.speed_mps)
        if speed > self.timing.standstill_mps + 0.1:
            self.rolled_in_stop = True
        if speed > 0.0:
            self.standstill_since = None
        elif self.standstill_since is None:
            self.standstill_since = now
        # A failed DAC may hold its last voltage: the enable line is what stops the motors.
        if released or (enable and not self._controlled(now, volts)):
            regen = self.world.dac.volts(self.regen_channel)
            detail = (
                f"enable={enable} ebrake_release={released} throttle={volts:.2f} V "
                f"regen={regen:.2f} V"
            )
            expected = {} if self._controlled_may_last(now) else {"motors_enabled": False}
            self._flag("H1", now, detail, **expected)
        return allowed

    def _power_off_demanded(self, now: float) -> bool:
        """A cause that makes the drive suspect has surely been acted on (its deadline passed):
        category 0 from then until the next arming."""
        due = (self.power_off_from, self.tripped_at)
        return any(from_s is not None and now >= from_s for from_s in due)

    def _controlled_may_last(self, now: float) -> bool:
        """A controlled stop may still keep the drive powered now (the time bound, standstill)."""
        if self._power_off_demanded(now) or self.demand_since is None:
            return False
        if now > self.demand_since + CONTROLLED_STOP_LIMIT_S:
            return False
        # A standstill the sensor proved (it read motion in this stop, with no throttle since):
        # the controller sees it within a reading.
        still = self.standstill_since
        proven = self.rolled_in_stop and not (self.sensor_ever_dead or self.sensor_dead)
        return not (proven and still is not None and now > still + STANDSTILL_GRACE_S)

    def _controlled(self, now: float, volts: float) -> bool:
        """The enable line high as a controlled stop: throttle at 0 V, the regenerative brake
        applied, within the stop's bounds."""
        regen = self.world.dac.volts(self.regen_channel)
        return volts <= 0.0 and regen > 0.0 and self._controlled_may_last(now)

    def _dac_unsure(self, now: float) -> bool:
        """A DAC whose writes fail may hold an old voltage until a period after they work."""
        rewrite_s = self.dac_back_at + 2 * self.timing.control_period_s
        return "dac_fail" in self.faults or now <= rewrite_s

    def _h2(self, now: float, volts: float) -> None:
        mode = self.switch
        # The switch's position travels in the IBUS frames: corrupted or lost ones delay it.
        shown_s = max(self.switch_shown_s, self.rc_blind_until)
        settled_s = self._past_hang(shown_s, shown_s + self.timing.settle_s)
        if volts <= 0.0 or mode is ControlMode.STOP or now < settled_s:
            return
        if not self.sources[mode].seen_zero:
            self._flag("H2", now, f"{mode.name} never at zero throttle; throttle={volts:.2f} V")

    def _h3(self, now: float, enable: bool, released: bool, volts: float) -> None:
        if self.tripped_at is None or now < self.tripped_at + 0.010:
            return
        pulse = self.world.pwm.steering.pulse_s
        stuck_dac = self._dac_unsure(now)
        moved = self.trip_hold.moved(pulse, now) and not self.timing.steering_boosted
        if enable or released or (volts > 0.0 and not stuck_dac) or moved:
            self._flag(
                "H3",
                now,
                f"after the trip: enable={enable} ebrake_release={released} "
                f"throttle={volts:.2f} V pulse={pulse * 1000:.3f} ms",
                steering_held_since_s=self.trip_hold.from_s,
            )

    def _h4(self, now: float, enable: bool, volts: float) -> None:
        """Judged with the wheel sensor dead too: its standstill must not count, and without it
        the brake held for the long dwell proves standstill; with that brake failed as well,
        nothing the controller sees can (a double fault, `docs/SAFETY.md` row 19)."""
        if not enable or volts <= 0.0 or (self.sensor_dead and self.brake_failed):
            return
        speed, standstill = self.world.vehicle.state.speed_mps, self.timing.standstill_mps
        if self.sensor_dead and self.died_at_mps <= self.timing.unnoticed_death_mps:
            # Died unnoticed while rolling this slowly: its 0 m/s reads like a stop, and the
            # robot, undriven since (driving would leave the standstill unproven), is slower.
            standstill = max(standstill, self.died_at_mps)
        forward = self.world.gpio["motors_forward"].level
        reverse = self.world.gpio["motors_reverse"].level
        if (reverse and speed > standstill) or (forward and speed < -standstill):
            direction = "reverse" if reverse else "forward"
            self._flag("H4", now, f"driven {direction} at {speed:.2f} m/s")

    def _h5(self, now: float, cut: bool) -> None:
        """Judged while the drive must be cut and is (driving on is H1's)."""
        hold = self.stop_hold
        if not cut:
            hold.release()
            return
        duty, pulse = self.world.pwm.hydrobrake.duty, self.world.pwm.steering.pulse_s
        if duty < FULL_DUTY:
            self._flag("H5", now, f"in STOP: hydraulic brake at {duty:.2f} duty")
        if hold.moved(pulse, now) and not self.timing.steering_boosted:
            held_ms = (hold.pulse_s or 0.0) * 1000
            self._flag(
                "H5",
                now,
                f"in STOP: steering pulse {pulse * 1000:.3f} ms, held at {held_ms:.3f} ms",
                steering_held_since_s=hold.from_s,
            )

    def _h7(self, now: float, released: bool) -> None:
        """While the e-brake is engaged and the robot moves, it slows by `REQUIRED_DECEL_MPS2`
        for as long as some brake can work."""
        speed = abs(self.world.vehicle.state.speed_mps)
        if released or speed <= STANDSTILL_LIMIT_MPS:  # a controlled stop may end there
            self.braking_from = None
            return
        if self.braking_from is None:
            self.braking_from, self.braking_credit_s, self.braking_seen_s = (now, speed), 0.0, now
            return
        began_s, start_mps = self.braking_from
        if self._some_brake_works(now, began_s):
            self.braking_credit_s += now - self.braking_seen_s
        self.braking_seen_s = now
        slowed_mps = REQUIRED_DECEL_MPS2 * max(self.braking_credit_s - BRAKE_REACT_S, 0.0)
        allowed_mps = start_mps + 0.05 - slowed_mps
        if speed > allowed_mps:
            forward = self.world.vehicle.state.speed_mps > 0.0
            bound = {"speed_max_mps": allowed_mps} if forward else {"speed_min_mps": -allowed_mps}
            self._flag(
                "H7",
                now,
                f"braking since {began_s:.3f} s from {start_mps:.2f} m/s: {speed:.2f} m/s, "
                f"at most {allowed_mps:.2f} m/s",
                **bound,
            )
            self.braking_from = (now, speed)  # once a stop, not at every pass after
            self.braking_credit_s = 0.0

    def _h9(self, now: float, released: bool) -> None:
        """A source taking over moves the steering no faster than the handover rate."""
        blend = self.blend
        if blend is None or self.timing.steering_boosted:
            return
        if not released or now < blend.from_s:
            blend.last = None  # in STOP the steering holds; the move counts once driving
            return
        pulse_s, servo = self.world.pwm.steering.pulse_s, self.timing.servo
        target_s = servo.pulse_s(self.sources[blend.source].steering_norm)
        if abs(pulse_s - target_s) <= 0.02 * servo.half_span_s:
            self.blend = None
            return
        speed = abs(self.world.vehicle.state.speed_mps)
        rate = (
            REQUIRED_HANDOVER_RATE * min(1.0, 1.0 / speed)
            if speed > 0.0
            else REQUIRED_HANDOVER_RATE
        )
        last = blend.last
        blend.last = (now, pulse_s)
        if last is None or now <= last[0]:
            return
        moved_norm = abs(pulse_s - last[1]) / servo.half_span_s
        allowed_norm = rate * (now - last[0]) + 0.02
        if moved_norm > allowed_norm:
            step_s = allowed_norm * servo.half_span_s
            bound = (
                {"steering_pulse_max_s": last[1] + step_s}
                if pulse_s > last[1]
                else {"steering_pulse_min_s": last[1] - step_s}
            )
            self._flag(
                "H9",
                now,
                f"taking over from {blend.source.name}: the steering moved {moved_norm:.2f} in"
                f" {now - last[0]:.3f} s at {speed:.2f} m/s (at most {allowed_norm:.2f})",
                **bound,
            )

    def _some_brake_works(self, now: float, began_s: float) -> bool:
        """The spring or hydraulic brake works, or the drive can regenerate: a controlled
        stop's first `REGEN_WINDOW_S` (its cause leaves the drive healthy and the DAC works)."""
        if not (self.ebrake_failed and self.brake_failed):
            return True
        healthy = not (self._power_off_demanded(now) or self._dac_unsure(now))
        return healthy and now - began_s <= REGEN_WINDOW_S

    def exited(self, now: float) -> None:
        """The controller ended on a failed output: H8, every other output safe."""
        world = self.world
        levels = {
            "motors_enable": not world.gpio["motors_enable"].level,
            "ebrake_release": not world.gpio["ebrake_release"].level,
            "hydrobrake": world.pwm.hydrobrake.duty >= FULL_DUTY,
            "dac": world.dac.volts(self.throttle_channel) <= 0.0 or self._dac_unsure(now),
        }
        unsafe = [name for name, safe in levels.items() if not safe and name not in self.dead_lines]
        if unsafe:
            self._flag("H8", now, f"after the controller ended: not safe: {', '.join(unsafe)}")

    def line_died(self, name: str) -> None:
        """Every write to the output `name` fails from now on."""
        self.dead_lines.add(name)

    def _h6(self, now: float, enable: bool, volts: float) -> None:
        """Brake and throttle together for longer than a control period: the brake and the
        drive may be written by tasks of their own, one a pass ahead of the other."""
        if not enable or volts <= 0.0:  # most passes: nothing to read
            self.brake_with_throttle_at = None
            return
        regen = self.world.dac.volts(self.regen_channel)
        duty = self.world.pwm.hydrobrake.duty
        if (regen <= 0.0 and duty <= 0.0) or self._dac_unsure(now):
            self.brake_with_throttle_at = None
            return
        if self.brake_with_throttle_at is None:
            self.brake_with_throttle_at = now
        if now - self.brake_with_throttle_at > self.timing.control_period_s + 0.001:
            detail = f"throttle {volts:.2f} V with regen {regen:.2f} V, hydraulic duty {duty:.2f}"
            self._flag("H6", now, detail)
