"""The hazard oracle: what the robot's outputs must be, judged from what was done to the robot.

It never asks the controller what it believes: it is told every action and fault the test (or
`bywire verify`) applies, and after every pass of the loop it reads the simulated hardware (the
enable line, the DAC's throttle volts, the e-brake line, the steering pulse, the direction lines
and the vehicle's true speed) and checks the output invariants of `docs/SAFETY.md` (H1..H11, one
pure check each in `checks/`).

What it was told is kept in small parts: the faults in force (`FaultsInForce`), what may delay
the controller (`Delays`), the stops requested and their deadlines (`StopLedger`), the switch
and the armings it makes (`ArmingTracker`), and what is broken in the robot (`Plant`). Each
violation carries what the hardware should have shown (`Violation.expected`, conditions of a
scenario's expectation), so `bywire verify` can write it as a scenario that fails there.

Where the controller's timing makes the expected level uncertain (a debounce in progress, a
fault just injected) the oracle leans towards allowing: it must never flag a correct robot.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode
from bywire.sim.verify.oracle.arming import ArmingTracker
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from bywire.sim.verify.oracle.causes import CAN_MODE_ONLY, OracleCause
from bywire.sim.verify.oracle.checks.h1 import StopFacts, StopWatch, check_h1
from bywire.sim.verify.oracle.checks.h2 import HandoverFacts, check_h2
from bywire.sim.verify.oracle.checks.h3 import TripFacts, check_h3
from bywire.sim.verify.oracle.checks.h4 import MotionFacts, check_h4
from bywire.sim.verify.oracle.checks.h5 import check_h5
from bywire.sim.verify.oracle.checks.h6 import check_h6
from bywire.sim.verify.oracle.checks.h7 import BrakeFacts, Braking, check_h7
from bywire.sim.verify.oracle.checks.h8 import check_h8
from bywire.sim.verify.oracle.checks.h9 import check_h9
from bywire.sim.verify.oracle.checks.h10 import BrokenFacts, Unnoticed, check_h10
from bywire.sim.verify.oracle.checks.h11 import LimitFacts, check_h11
from bywire.sim.verify.oracle.checks.hold import SteeringHold
from bywire.sim.verify.oracle.delays import Delays
from bywire.sim.verify.oracle.faults_in_force import FaultsInForce
from bywire.sim.verify.oracle.invariants import Violation
from bywire.sim.verify.oracle.ledger import StopLedger
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.plant import Plant
from bywire.sim.verify.oracle.requirements import TRUST_REGAINED_S

STOP = ControlMode.STOP

# Each check's facts are a frozen value of a few flags and figures that change seldom (a fault
# begins, the switch moves, the watchdog trips), made on every pass: each distinct one is made
# once and shared (equal arguments, equal facts; typed, so a flag is never taken for a number).
FACTS_KEPT = 64
_stop_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(StopFacts)
_handover_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(HandoverFacts)
_trip_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(TripFacts)
_motion_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(MotionFacts)
_brake_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(BrakeFacts)
_broken_facts = functools.lru_cache(maxsize=FACTS_KEPT, typed=True)(BrokenFacts)


@dataclass(slots=True)
class CheckMemory:
    """What the checks remember from one pass to the next."""

    stop_watch: StopWatch = field(default_factory=StopWatch)  # H1
    trip_hold: SteeringHold = field(default_factory=SteeringHold)  # H3: held since a trip
    stop_hold: SteeringHold = field(default_factory=SteeringHold)  # H5: held in STOP
    brake_with_throttle_at: float | None = None  # H6
    braking: Braking | None = None  # H7
    unnoticed: Unnoticed = field(default_factory=Unnoticed)  # H10
    over_limit: bool = False  # H11: past the speed limit's bound at the last pass


class HazardOracle:
    """Told every action; `observe` after every pass checks H1..H11 on the world's hardware."""

    __slots__ = (
        "arming",
        "checks",
        "delays",
        "faults",
        "ledger",
        "memory",
        "plant",
        "timing",
        "violations",
        "world",
    )

    def __init__(
        self,
        world: SimWorld,
        timing: OracleTiming | None = None,
    ) -> None:
        self.world = world
        self.timing = timing = timing if timing is not None else OracleTiming()
        self.violations: list[Violation] = []
        self.checks = 0
        self.faults = FaultsInForce(timing)
        self.delays = Delays(timing)
        self.ledger = StopLedger(timing, self.faults, self.delays)
        self.arming = ArmingTracker(timing, self.ledger, self.faults, self.delays)
        self.plant = Plant(world.sensors_fitted)
        self.memory = CheckMemory()

    @property
    def switch(self) -> ControlMode:
        """Where the mode switch is."""
        return self.arming.switch

    # --- what was done: the operator and the computer -----------------------------------------

    def set_switch(self, mode: ControlMode, now: float) -> None:
        self.arming.set_switch(mode, now)

    def set_switch_between(self, now: float) -> None:
        """The switch read between positions: STOP, but no stay at STOP (row 72)."""
        self.arming.set_between(now)

    def set_throttle(self, source: ControlMode, throttle_norm: float, now: float) -> None:
        """`throttle_norm`: the stick's position (RC) or the computer's set-point (CAN); the
        controller reads a stick inside its deadband as zero."""
        if source is ControlMode.RC:
            throttle_norm = self.timing.sticks.throttle.read_norm(throttle_norm)
        self.arming.set_throttle(source, throttle_norm, now)

    def set_steering(self, source: ControlMode, steering_norm: float, _now: float) -> None:
        """As `set_throttle`: a stick inside its deadband steers straight ahead."""
        if source is ControlMode.RC:
            steering_norm = self.timing.sticks.steering.read_norm(steering_norm)
        self.arming.set_steering(source, steering_norm)

    def re_enable(self, now: float) -> None:
        self.arming.re_enable(now)

    def stop_event(self, cause: OracleCause, now: float) -> None:
        """Something that demands STOP happened at `now`."""
        self.ledger.request(cause, now)

    def switched_to_lost_can(self, now: float) -> None:
        """The switch moved to CAN while a CAN-bound fault is in force: the controller stops
        as a silent computer would stop it, but only once the move counts, after the debounce's
        frames (`ArmingTracker.settled_s`): until then it rightly stays in the source it left
        (docs/SAFETY.md row 74)."""
        self.ledger.request(OracleCause.CAN_LOST, now, counts_from_s=self.arming.settled_s())

    # --- what was done: faults -------------------------------------------------------------------

    def fault(self, cause: OracleCause, active: bool, now: float) -> None:
        """A fault condition begins (and stops the robot) or ends; saying it again changes
        nothing (a remote stop already requested does not arrive again)."""
        if active == (cause in self.faults):
            return
        self.faults.changed_at = now
        if cause is OracleCause.RC_LINK_LOST:
            self.arming.link(active, now)
        if active:
            self._begins(cause, now)
        else:
            self._ends(cause, now)

    def _begins(self, cause: OracleCause, now: float) -> None:
        faults, ledger = self.faults, self.ledger
        # A cause of CAN mode only stops the robot once the switch's move to CAN has counted.
        counts_s = self.arming.settled_s() if cause in CAN_MODE_ONLY else 0.0
        if cause is OracleCause.CAN_IMPOSTOR:
            # Driving, not stopping: a controlled stop keeps the enable line high too, but the
            # e-brake engaged says STOP. Still in RC, the move to CAN not yet counted, nothing
            # latches before it counts.
            gpio = self.world.gpio
            faults.impostor_met_drive = gpio["motors_enable"].level and gpio["ebrake_release"].level
            faults.impostor_counts_s = counts_s
        faults.causes.add(cause)
        faults.began[cause] = (now, ledger.armed)
        ledger.request(cause, now, counts_from_s=counts_s)
        unseen = now - ledger.rc_borne_at < self.timing.unseen_s
        if cause is OracleCause.RC_LINK_LOST and unseen and ledger.deadline_s is not None:
            # No frame may have carried what the link said just before it died: only the
            # link's own timeout stops the robot then.
            lost_s = now + self.timing.deadline_s(cause)
            ledger.deadline_s = max(ledger.deadline_s, lost_s)

    def _ends(self, cause: OracleCause, now: float) -> None:
        faults = self.faults
        faults.causes.discard(cause)
        if cause in CAN_MODE_ONLY and not faults.any_of(CAN_MODE_ONLY):
            lingers_s = TRUST_REGAINED_S if cause is OracleCause.CAN_IMPOSTOR else 0.0
            self.ledger.can_mode_fault_over(now + lingers_s)
        if cause is OracleCause.DAC_FAIL:
            faults.dac_back_at = now
        self.ledger.ended(cause, now)
        began_s, armed_before = faults.began.pop(cause, (now, False))
        if now - began_s < faults.unnoticed_s(cause):  # it may have passed unseen
            if armed_before:
                self.ledger.arm()
            else:
                self.ledger.passed_unseen(cause)

    def fault_elsewhere(self, cause: OracleCause, now: float) -> None:
        """A CAN-bound fault begins while the switch is not at CAN: it refuses arming into
        CAN; RC drives on."""
        self.faults.note(cause, now)

    def chatter(self, frames: int, now: float) -> None:
        """The mode switch bounces: of the next `frames` frames every other one reads STOP."""
        self.arming.chatter(frames, now)

    def implausible(self, frames: int, now: float) -> None:
        """The next `frames` IBUS frames carry a pulse no stick gives."""
        self.ledger.implausible(frames, now)

    def blind(self, source: ControlMode, from_s: float, until_s: float) -> None:
        """Frames of `source` may be lost (corrupted, garbled) from `from_s` until `until_s`:
        what they carry may reach the controller that much later, or never."""
        if source is ControlMode.RC:
            self.ledger.rc_blind(from_s, until_s)
        self.delays.blind(source, from_s, until_s)

    def dac_failing(self, now: float, *, every_other: bool) -> None:
        """The DAC NAKs every write, or every other one (which latches later: the leaky count
        reaches its limit at the fourth failure, where failing pairs reach it at the second)."""
        faults = self.faults
        if OracleCause.DAC_FAIL not in faults:
            faults.dac_every_other = every_other
        else:
            faults.dac_every_other |= every_other  # a failure under way: the later latch counts
        self.fault(OracleCause.DAC_FAIL, True, now)

    def slow_writes(self, lag_s: float) -> None:
        """Every pass that writes the DAC may end `lag_s` later (0: transfers are ordinary)."""
        self.delays.write_lag_s = lag_s

    def hang(self, from_s: float, until_s: float) -> None:
        """The loop's next write after `from_s` hangs until `until_s`, too short to trip the
        watchdog: whatever the loop had still to act on waits until it runs again."""
        self.delays.hang(from_s, until_s)
        self.ledger.postpone()

    def stall(self, started_s: float, trips_at_s: float) -> None:
        """A write hangs from `started_s` past the watchdog's limit: it trips at `trips_at_s`.
        With the switch already at STOP the trip is acknowledged as it happens (S2): H3 has
        nothing to hold, and leaving STOP is an arming like any other."""
        if self.arming.switch is not STOP:
            self.ledger.tripped(trips_at_s)
            self.memory.trip_hold = SteeringHold()
            self.faults.dac_writes_from = float("inf")  # the gate refuses them until STOP
        self.ledger.request(OracleCause.WATCHDOG, started_s)

    def sensor_dies(self) -> None:
        self.plant.sensor_dies(self.world.vehicle.state.speed_mps)

    def sensor_restored(self) -> None:
        self.plant.sensor_restored()

    def ebrake_fails(self) -> None:
        """The spring brake does not engage (nothing detects it: `docs/SAFETY.md` row 6)."""
        self.plant.ebrake_failed = True

    def hydrobrake_fails(self, failed: bool) -> None:
        """The hydraulic brake builds no pressure (or works again)."""
        self.plant.hydrobrake_failed = failed

    def servo_stuck(self, stuck: bool) -> None:
        """The steering servo stays where it is (or moves again)."""
        self.plant.servo_stuck = stuck

    def line_died(self, name: str) -> None:
        """Every write to the output `name` fails from now on."""
        self.plant.dead_lines.add(name)

    # --- what the hardware shows -----------------------------------------------------------------

    def observe(self, now: float) -> None:
        """Check every invariant on the hardware as it is at `now`."""
        self.checks += 1
        self.arming.resolve(now)
        self.judge(Outputs.read(self.world), now)

    def judge(self, out: Outputs, now: float) -> None:
        """Check H1..H7 and H9..H11 on `out`, what the hardware shows at `now` (a debounce that
        has just ended is `observe`'s to resolve first)."""
        arming, ledger, plant, timing, memory = (
            self.arming,
            self.ledger,
            self.plant,
            self.timing,
            self.memory,
        )
        allowed = ledger.allows(now) or arming.pending is not None
        if allowed and ledger.armed:  # re-armed: what a category 0 cause demanded is over
            ledger.power_off_by.clear()
        power_off = ledger.power_off_demanded(now)
        dac_unsure = self.faults.dac_unsure(now)
        boosted = timing.steering_boosted
        untrusted = plant.sensor_ever_dead or plant.sensor_dead
        stop = _stop_facts(allowed, power_off, untrusted, timing.standstill_mps)
        memory.stop_watch, h1 = check_h1(memory.stop_watch, out, stop, now)
        switch = arming.switch
        seen_zero = switch is STOP or arming.sources[switch].seen_zero
        handover = _handover_facts(switch, arming.settled_s(), seen_zero)
        h2 = check_h2(handover, out.throttle_volts if out.enable else 0.0, now)
        trip = _trip_facts(ledger.tripped_at, dac_unsure, boosted)
        memory.trip_hold, h3 = check_h3(memory.trip_hold, out, trip, now)
        motion = _motion_facts(
            plant.sensor_dead,
            plant.died_at_mps,
            plant.hydrobrake_failed,
            timing.standstill_mps,
            timing.unnoticed_death_mps,
        )
        h4 = check_h4(out, motion, now)
        cut = not (allowed or out.released)
        memory.stop_hold, h5 = check_h5(memory.stop_hold, out, cut, boosted, now)
        memory.brake_with_throttle_at, h6 = check_h6(
            memory.brake_with_throttle_at, out, dac_unsure, timing.control_period_s, now
        )
        healthy = not (power_off or dac_unsure)
        brakes = _brake_facts(plant.ebrake_failed, plant.hydrobrake_failed, healthy)
        # H7 weighs the speed against the time the robot had to slow: the world's time, which a
        # stalled write moved on while the pass that ends the stall still bears its start
        # (`now`); on that pass the speed is already the stall's end's.
        world_s = max(now, self.world.clock.now())
        memory.braking, h7 = check_h7(memory.braking, out, brakes, world_s)
        h9 = None
        taking = arming.taking
        if taking is not None and not boosted:
            target = arming.sources[taking.source].steering_norm
            arming.taking, h9 = check_h9(taking, out, target, timing.servo, now)
        broken = _broken_facts(
            plant.sensors_fitted,
            plant.hydrobrake_failed,
            plant.servo_stuck,
            timing.boost_gain,
            timing.control_period_s,
        )
        memory.unnoticed, h10 = check_h10(memory.unnoticed, out, broken, now)
        limit = LimitFacts(
            timing.speed_limit_mps,
            not plant.sensor_ever_dead,
            plant.ebrake_failed and plant.hydrobrake_failed,
        )
        memory.over_limit, h11 = check_h11(memory.over_limit, out, limit, now)
        found = (h1, h2, h3, h4, *h5, h6, h7, h9, h10, h11)
        self.violations.extend(violation for violation in found if violation is not None)

    def exited(self, now: float) -> None:
        """The controller ended on a failed output: H8, every other output safe."""
        out = Outputs.read(self.world)
        violation = check_h8(out, self.plant.dead_lines, self.faults.dac_unsure(now), now)
        if violation is not None:
            self.violations.append(violation)
