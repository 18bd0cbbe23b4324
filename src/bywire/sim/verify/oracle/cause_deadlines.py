"""How long the controller may take to act on each cause, and the servo's and sticks' calibration.

Each deadline is a detection threshold (an input's timeout, the watchdog) plus the frame,
command period and control periods in which the controller may notice it and act. Those figures
are bounded by the requirements (`requirements.REQUIRED`, by R- id): a robot file that promises
less time is held to its promise, one that allows itself more is judged as if it kept the
requirement (R-CONFIG-SAFETY). What the controller must then do, and how fast, is the
requirements' alone. Facts of the simulated world are the file's: the RC receiver's frame
period, the servo's calibration, the sticks' deadbands, whether the steering is boosted; and the
switch's debounce,
which only says when an arming may count (the oracle waits for it, leaning to allowing).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.config.consistency import CONTROL_TASKS
from bywire.config.deadlines import STOP_RESPONSE_S
from bywire.config.tree import RobotConfig
from bywire.control.dac_health import DAC_TRANSFERS_PER_PASS
from bywire.control.rc_mapping import AxisCalibration
from bywire.control.steering import SteeringConfig
from bywire.model import MovementCommand
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.requirements import CAN_PERIOD_S, REQUIRED, Figure


@dataclass(frozen=True, slots=True)
class ServoPulses:
    """The servo's calibration (a physical fact of the robot, not a deadline): a steering
    norm's pulse, each side of centre on its own span (full left at `min_pulse_s`, full right at
    `max_pulse_s`, as the robot file calibrates them). One span for both sides, the shorter,
    judged a legal asymmetric calibration's handover on the longer side 4 times too fast (H9:
    `bywire verify --draw-robots 10 --seed 2`, file 4, campaign 106: `min_pulse_s` 1.375 ms)."""

    center_s: float = 0.0015
    below_s: float = 0.0005  # centre to min_pulse_s
    above_s: float = 0.0005  # centre to max_pulse_s
    reverse: bool = False

    @classmethod
    def of(cls, servo: SteeringConfig) -> ServoPulses:
        below_s = servo.center_pulse_s - servo.min_pulse_s
        above_s = servo.max_pulse_s - servo.center_pulse_s
        return cls(servo.center_pulse_s, below_s, above_s, servo.reverse)

    @property
    def half_span_s(self) -> float:
        """The shorter side's span: tolerances in pulse are taken on it."""
        return min(self.below_s, self.above_s)

    def pulse_s(self, steering_norm: float) -> float:
        norm = -steering_norm if self.reverse else steering_norm
        return self.center_s + norm * (self.above_s if norm >= 0.0 else self.below_s)

    def norm_of(self, pulse_s: float) -> float:
        """The steering norm whose pulse is `pulse_s` (the inverse of `pulse_s`)."""
        offset_s = pulse_s - self.center_s
        norm = offset_s / (self.above_s if offset_s >= 0.0 else self.below_s)
        return -norm if self.reverse else norm


@dataclass(frozen=True, slots=True)
class StickDeadband:
    """One RC stick's deadband (a calibration of the robot, as the servo's): a stick nearer its
    centre than `deadband_norm` reads as centred (zero throttle, straight ahead), whatever the
    operator meant. Its position travels as a whole number of microseconds, so within
    `rounding_norm` (half a microsecond of the stick's shorter half) of the deadband's edge it
    may read either way; the oracle then takes it as centred, leaning to allowing (an arming at
    zero throttle, a source seen at zero)."""

    deadband_norm: float = 0.02
    rounding_norm: float = 0.001

    @classmethod
    def of(cls, axis: AxisCalibration) -> StickDeadband:
        half_raw = min(axis.max_raw - axis.center_raw, axis.center_raw - axis.min_raw)
        return cls(axis.deadband_norm, 0.5 / max(half_raw, 1))

    def read_norm(self, stick_norm: float) -> float:
        """What the controller may read of a stick at `stick_norm`."""
        near = abs(stick_norm) <= self.deadband_norm + self.rounding_norm
        return 0.0 if near else stick_norm


@dataclass(frozen=True, slots=True)
class RcSticks:
    """The RC sticks' deadbands, from the robot file (`[rc.steering]`, `[rc.throttle_brake]`).
    The ends, the centre and `reverse` need nothing here: the simulated transmitter sends a
    position with the same calibration the controller reads it with."""

    steering: StickDeadband = field(default_factory=StickDeadband)
    throttle: StickDeadband = field(default_factory=StickDeadband)


@dataclass(frozen=True, slots=True)
class OracleTiming:
    """How long the controller may take for each thing (the defaults: the figures
    `docs/SAFETY.md` gives; `for_robot`: a robot file's, bounded by the requirements)."""

    frame_s: float = 0.0077  # the RC receiver's frame period
    debounce_frames: int = 3
    rc_timeout_s: float = 0.100
    can_timeout_s: float = 0.100
    watchdog_s: float = 0.200
    control_period_s: float = 0.010
    driving_period_s: float = 0.010  # the task that writes the DAC
    dac_transfer_s: float = 0.0035  # the slowest transfer that is no fault (the file's budget)
    standstill_mps: float = 0.05
    # The fastest a wheel sensor can die unnoticed: its drop to 0 m/s is then within the speed
    # check's step tolerance plus what braking explains in a pass (docs/SAFETY.md row 27).
    unnoticed_death_mps: float = 0.45
    steering_boosted: bool = False  # the pulse settles onto a held set-point (boost_gain > 0)
    boost_gain: float = 0.0  # how far the pulse may overshoot the set-point (H10)
    servo: ServoPulses = field(default_factory=ServoPulses)
    sticks: RcSticks = field(default_factory=RcSticks)
    speed_limit_mps: float | None = None  # the file's `[limits] max_speed_mps` (H11)

    @classmethod
    def for_robot(cls, robot: RobotConfig) -> OracleTiming:
        """The deadlines for `robot`: its figures, each bounded by the requirement's."""
        slowest_hz = min(robot.tasks.rate_hz(name) for name in CONTROL_TASKS)
        period_s = bounded(Figure.CONTROL_PERIOD_S, 1.0 / slowest_hz)
        interlocks = robot.interlocks
        blind_spot_mps = (
            interlocks.speed_step_tolerance_mps + interlocks.speed_max_change_mps2 * period_s
        )
        return cls(
            frame_s=robot.sim.rc_frame_period_s,
            debounce_frames=robot.supervisor.debounce_frames,
            rc_timeout_s=bounded(Figure.RC_TIMEOUT_S, robot.timeouts.rc_timeout_s),
            can_timeout_s=bounded(
                Figure.CAN_TIMEOUT_S, robot.timeouts.can_timeout_s(MovementCommand.__name__)
            ),
            watchdog_s=bounded(Figure.WATCHDOG_S, robot.timeouts.watchdog_s),
            control_period_s=period_s,
            # A pass within its budget may outlast a fast task's period (its DAC transfers
            # within theirs): the DAC is written no more often than its passes end.
            driving_period_s=bounded(
                Figure.DRIVING_PERIOD_S,
                max(1.0 / robot.tasks.rate_hz("driving"), robot.timeouts.pass_budget_s),
            ),
            dac_transfer_s=bounded(Figure.DAC_TRANSFER_S, robot.timeouts.dac_transfer_budget_s),
            standstill_mps=bounded(Figure.STANDSTILL_MPS, interlocks.standstill_speed_mps),
            unnoticed_death_mps=bounded(Figure.BLIND_SPOT_MPS, blind_spot_mps),
            steering_boosted=robot.steering.servo.boost_gain > 0.0,
            boost_gain=robot.steering.servo.boost_gain,
            servo=ServoPulses.of(robot.steering.servo),
            sticks=RcSticks(
                StickDeadband.of(robot.rc.mapping.steering),
                StickDeadband.of(robot.rc.mapping.throttle_brake),
            ),
            speed_limit_mps=robot.limits.max_speed_mps,
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

    @property
    def frame_stop_s(self) -> float:
        """A stop an IBUS frame carries: the promise (`bywire.config.deadlines.OPERATOR_STOP`:
        the frame that carries it, then one control period to the spring brake, whatever the
        task rates: the frame wakes the loop), then the drive's transfers after the brakes (a
        controlled stop's throttle at 0 V and its regenerative brake), each within its budget."""
        return self.frame_s + STOP_RESPONSE_S + DAC_TRANSFERS_PER_PASS * self.dac_transfer_s

    def deadline_s(self, cause: OracleCause) -> float:
        """How long after `cause` the outputs may still drive: detection, then a frame or
        command period, then the control periods that act on it."""
        frame, period = self.frame_s, self.control_period_s
        return {
            OracleCause.SWITCH_STOP: self.frame_stop_s,
            OracleCause.RC_FAILSAFE: self.frame_stop_s,
            OracleCause.RC_IMPLAUSIBLE: self.frame_stop_s,
            OracleCause.RC_LINK_LOST: self.rc_timeout_s + frame + period + 0.0073,
            OracleCause.REMOTE_STOP: CAN_PERIOD_S + 2 * period + 0.005,
            OracleCause.CAN_LOST: self.can_timeout_s + 2 * CAN_PERIOD_S + period,
            OracleCause.CAN_UNPLUGGED: self.can_timeout_s + 2 * CAN_PERIOD_S + period,
            OracleCause.CAN_IMPOSTOR: 0.200,  # its frames are judged over a window of 16 counters
            # Three failed writes (the leaky count), a period to act, and two of margin.
            OracleCause.DAC_FAIL: 6 * self.driving_period_s,
            # The next transfer (within a driving period) crawls; enable low as it returns.
            OracleCause.DAC_SLOW: self.driving_period_s + 2 * period + 0.005,
            OracleCause.WATCHDOG: self.watchdog_s + 3 * period,
            # The promise of issue 44: one control period plus the debounce, the oracle's own
            # figure for contact bounce (not the controller's).
            OracleCause.ESTOP_PRESSED: period + ESTOP_BOUNCE_S,
            OracleCause.ESTOP_WIRE: period + ESTOP_BOUNCE_S,
        }[cause]

    def unnoticed_s(self, cause: OracleCause) -> float:
        """How long a fault must last before the controller can have noticed it at all: one
        that ends sooner may have passed unseen (a link back before its timeout)."""
        return {
            OracleCause.RC_LINK_LOST: self.rc_timeout_s + 0.010,
            OracleCause.RC_FAILSAFE: 0.010,
            OracleCause.REMOTE_STOP: 0.025,
            OracleCause.CAN_LOST: self.can_timeout_s + 0.025,
            OracleCause.CAN_UNPLUGGED: self.can_timeout_s + 0.025,
            OracleCause.CAN_IMPOSTOR: 0.080,
            OracleCause.DAC_FAIL: 3 * self.driving_period_s,
        }.get(cause, 0.0)


ESTOP_BOUNCE_S = 0.020
"""The contact bounce an E-stop's debounce may absorb: switches and relays settle in 5-20 ms."""


def bounded(figure: Figure, configured: float) -> float:
    """`configured`, a robot file's figure, never laxer than the requirement's."""
    return REQUIRED[figure].bound(configured)
