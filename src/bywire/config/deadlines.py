"""The physical deadlines a robot file must keep, stated once, and the constraints they put on
its keys (R-CONFIG-SAFETY).

Each key is range-checked on its own by the loader; these rows are what several keys must do
together. Each states a deadline of `docs/SAFETY.md` with the requirement's own figures (never
the file's), and derives from it what the file's numbers must satisfy; a file that breaks one is
refused at load (exit 2), naming the deadline and the nearest safe values. `bywire verify`'s
oracle judges with the same requirement figures, so an unsafe file cannot also set its judge's
deadlines (issue 30: every task at 1 Hz, both dwells at 0 on a robot without a wheel sensor, or
the loosest speed check each switched a safety function off while every key was in range; issue
41: a steering tolerance of 2, a no-sensor brake demand at the hydraulic threshold, a controlled
stop demanding more than regeneration gives, a pressure monitor watching full duty only or
allowing 5 s).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from bywire.config.limits import DWELL_S, POSITIVE_NORM_PER_S
from bywire.config.reader import number_text
from bywire.config.security import PAIRING_WINDOW_S
from bywire.config.tree import RobotConfig
from bywire.control.dac_health import DAC_FAILURE_LIMIT, DAC_TRANSFERS_PER_PASS
from bywire.control.hydrobrake import hydrobrake_duty
from bywire.control.interlocks import InterlockConfig
from bywire.control.sensor_checks import MonitorConfig
from bywire.control.speed_check import blind_spot_mps
from bywire.control.stop import STANDSTILL_LIMIT_MPS
from bywire.model import MovementCommand
from bywire.protocol import ibus
from bywire.protocol.bittiming import frame_bits

MAX_CONTROL_PERIOD_S = 0.020
"""The longest a decision may wait for the next tick: a lost input reaches safe outputs within
its timeout plus this."""
DAC_FAILURE_DEADLINE_S = 0.060
"""Failing DAC writes reach safe outputs within this (the failure limit's writes, one a driving
period)."""
TOP_SPEED_MPS = 3.0
"""The fastest a robot of this class drives: what the no-sensor rule must stop it from."""
BRAKE_DECEL_MPS2 = 2.0
"""The least deceleration of the hydraulic brake at the no-sensor rule's brake demand."""
HYDRAULIC_FULL_DECEL_MPS2 = 4.0
"""The least deceleration the hydraulic brake gives at full duty; it falls in proportion with the
duty (Figure 13: the valve's duty sets the pressure). The simulated vehicle's
`max_hydraulic_decel_mps2`."""
REGEN_DECEL_MPS2 = 1.5
"""The least deceleration the drive's regenerative brake gives at full scale
(`MOTOR_FULL_SCALE_VOLTS`), without the rolling drag: what a controlled stop has left when both
mechanical brakes fail (docs/SAFETY.md row 37). The simulated vehicle's `max_regen_decel_mps2`."""
MOTOR_FULL_SCALE_VOLTS = 5.0
"""The motor controllers' full-scale input (thesis Table 2): regeneration scales with the volts."""
STEERING_DEVIATION_NORM = 0.3
"""A steering more than this off its command (of the -1..1 range; 9° of road-wheel angle on the
reference robot's 30°) is a fault the steering monitor must see."""
STUCK_SERVO_DEADLINE_S = 2.0
"""A servo stuck anywhere on its travel is noticed within this of the command it does not follow
(the worst case, full lock to full lock: the slowest acceptable servo's travel plus the margin;
1.43 s on the defaults)."""
FULL_TRAVEL_NORM = 2.0
"""The steering's travel from full left (-1) to full right (+1)."""
BLIND_SPOT_MPS = 0.5
"""A wheel sensor that dies faster than this is noticed (docs/SAFETY.md row 27)."""
HARDEST_STOP_DECEL_MPS2 = 15.0
"""The most a robot of this class decelerates: every brake at once, the spring brake, the
hydraulic brake at full duty and regeneration at full scale, with the rolling drag, on the
steepest road it drives, 30 % uphill (the simulated vehicle's 6 + 4 + 1.5 + 0.15 m/s² and 2.8
m/s² of gravity, rounded up; the default `speed_max_change_mps2`). The wheel-speed check must
take such a stop for one, never for a dying sensor (docs/SAFETY.md row 73)."""
WHEEL_SAMPLE_S = 0.005
"""The oldest a wheel-speed reading may be when a decision reads it: the sensor's own update
period (the simulated sensor's: the vehicle model's step). Two decisions a moment apart may read
two samples, one this much newer: the speed check judges the change on the time between the
decisions, so its tolerance must hold what the hardest stop takes off in one sample."""
DRIVE_ACCEL_MPS2 = 1.2
"""The least a robot of this class accelerates from standstill at full throttle on the flat,
before the drag (the simulated vehicle's `max_drive_accel_mps2`): with the drag, what a start
at the stuck-sensor check's throttle must get moving on (docs/SAFETY.md row 81)."""
ROLLING_DRAG_MPS2 = 0.15
"""The most rolling drag a robot of this class has (the simulated vehicle's
`rolling_drag_mps2`): below the throttle that overcomes it, a driven robot stands still."""
REVERSE_TOP_SPEED_MPS = 1.0
"""The top speed the class's drive fades to in reverse, the slower direction (the simulated
vehicle's `reverse_top_speed_mps`): its start is the slowest."""
STANDSTILL_HOLD_MAX_S = 0.5
"""The longest a controlled stop keeps a standing robot's drive powered (at 0 V, braking) before
power goes off: the standstill hold (`control/stop.py`) in which regeneration stops a robot that
a wheel sensor dying inside its blind spot hid (docs/SAFETY.md row 37)."""
STOP_RESPONSE_S = 0.010
"""One control period: the most a stop carried by a frame may take from the frame's period to
the brakes (docs/SAFETY.md: "the frame that carries the change, plus one control period")."""
IBUS_WIRE_S = ibus.FRAME_LENGTH * 10 / ibus.BAUD_RATE
"""An IBUS frame's time on the wire (8N1: 10 bits a byte): the frame period counts from when a
frame begins, the controller has it when it ends (2.8 ms)."""
HYDRO_FAILURE_DUTY = 0.2
"""A hydraulic brake that builds no pressure is a fault the pressure monitor must see at this
duty or more (docs/SAFETY.md row 5, Table 4)."""
HYDRO_FAILURE_DEADLINE_S = 0.5
"""A hydraulic brake that builds no pressure at `HYDRO_FAILURE_DUTY` or more is noticed within
this of the first decision commanding the duty (the pressure's build-up time plus one decision
period; 0.31 s on the defaults): 1.5 m at 3 m/s of braking that does nothing."""
FOREIGN_FRAMES_BETWEEN = 1
"""Frames of other nodes that may win arbitration between a command frame and its cryptographic
PDU: one that waited for the bus while the command was on it and has a lower id than the PDU."""


@dataclass(frozen=True, slots=True)
class Breach:
    """Keys that together break a deadline, how, and the nearest values that keep it."""

    deadline: str
    keys: tuple[str, ...]
    problem: str
    fix: str

    def __str__(self) -> str:
        keys = " + ".join(self.keys)
        return f"{keys}: breaks the deadline '{self.deadline}': {self.problem}; {self.fix}"


Check = Callable[[RobotConfig], list[Breach]]


@dataclass(frozen=True, slots=True)
class Deadline:
    """One physical deadline: its name, what it promises, and the check it puts on the keys."""

    name: str
    statement: str
    check: Check


def decision_period_s(robot: RobotConfig) -> float:
    """How long a decision may wait: one period of the fastest task (every due task decides)."""
    return 1.0 / max(rate for _, rate in robot.tasks.rates_hz)


def _input_loss(robot: RobotConfig) -> list[Breach]:
    period_s = decision_period_s(robot)
    if period_s <= MAX_CONTROL_PERIOD_S + 1e-12:
        return []
    keys = tuple(f"tasks.{name}_rate_hz" for name, _ in robot.tasks.rates_hz)
    fastest = max(robot.tasks.rates_hz, key=lambda row: row[1])[0]
    return [
        Breach(
            INPUT_LOSS.name,
            keys,
            f"the fastest task runs every {number_text(period_s)} s, so a lost RC link or a"
            f" silent computer is acted on up to {number_text(period_s)} s after its timeout",
            f"set tasks.{fastest}_rate_hz to {number_text(1.0 / MAX_CONTROL_PERIOD_S)} or more",
        )
    ]


def _dac_failure(robot: RobotConfig) -> list[Breach]:
    rate_hz = robot.tasks.rate_hz("driving")
    limit = DAC_FAILURE_LIMIT
    needed_hz = math.ceil(limit / DAC_FAILURE_DEADLINE_S)
    if rate_hz >= needed_hz:
        return []
    return [
        Breach(
            DAC_FAILURE.name,
            ("tasks.driving_rate_hz",),
            f"{limit} failing writes at {number_text(rate_hz)} Hz take"
            f" {number_text(limit / rate_hz)} s to stop the robot",
            f"set tasks.driving_rate_hz to {needed_hz} or more",
        )
    ]


def _no_reversal(robot: RobotConfig) -> list[Breach]:
    found: list[Breach] = []
    interlocks = robot.interlocks
    if interlocks.standstill_speed_mps > STANDSTILL_LIMIT_MPS:
        found.append(
            Breach(
                NO_REVERSAL.name,
                ("interlocks.standstill_speed_mps",),
                f"the robot would count as standing still at"
                f" {number_text(interlocks.standstill_speed_mps)} m/s and change direction there",
                f"set interlocks.standstill_speed_mps to {number_text(STANDSTILL_LIMIT_MPS)}"
                " or less",
            )
        )
    needed_s = TOP_SPEED_MPS / BRAKE_DECEL_MPS2
    if interlocks.unknown_speed_dwell_s < needed_s:
        found.append(
            Breach(
                NO_REVERSAL.name,
                ("interlocks.unknown_speed_dwell_s",),
                f"without a trusted speed (no sensor, or a dead one) the brake is held only"
                f" {number_text(interlocks.unknown_speed_dwell_s)} s before a direction change,"
                f" too short to stop from {number_text(TOP_SPEED_MPS)} m/s at"
                f" {number_text(BRAKE_DECEL_MPS2)} m/s²",
                f"set interlocks.unknown_speed_dwell_s to {number_text(needed_s)} or more",
            )
        )
    if interlocks.unknown_speed_dwell_s < interlocks.direction_dwell_s:
        found.append(
            Breach(
                NO_REVERSAL.name,
                ("interlocks.unknown_speed_dwell_s", "interlocks.direction_dwell_s"),
                "without a trusted speed the robot would wait less than it waits with one",
                f"set interlocks.unknown_speed_dwell_s to"
                f" {number_text(interlocks.direction_dwell_s)} or more",
            )
        )
    found.extend(_no_sensor_brake(robot))
    return found


def no_sensor_brake_needed_norm(threshold_norm: float) -> float:
    """The least brake demand whose hydraulic duty decelerates at `BRAKE_DECEL_MPS2`: the
    inverse of `hydrobrake_duty` at the duty that deceleration needs."""
    duty = BRAKE_DECEL_MPS2 / HYDRAULIC_FULL_DECEL_MPS2
    return threshold_norm + duty * (1.0 - threshold_norm)


def _no_sensor_brake(robot: RobotConfig) -> list[Breach]:
    """The no-sensor rule's dwell is long enough only if its brake demand brakes at
    `BRAKE_DECEL_MPS2`: the duty at the demand, not merely a demand above the threshold (issue
    41: a demand equal to the threshold gave duty 0)."""
    demand = robot.interlocks.unknown_speed_brake_norm
    threshold = robot.hydrobrake.threshold_norm
    duty = hydrobrake_duty(demand, threshold)
    decel_mps2 = duty * HYDRAULIC_FULL_DECEL_MPS2
    if decel_mps2 >= BRAKE_DECEL_MPS2 - 1e-9:
        return []
    needed = math.ceil(no_sensor_brake_needed_norm(threshold) * 1000 - 1e-6) / 1000
    return [
        Breach(
            NO_REVERSAL.name,
            ("interlocks.unknown_speed_brake_norm", "hydrobrake.threshold_norm"),
            f"the brake the no-sensor rule demands ({number_text(demand)}) gives the hydraulic"
            f" brake duty {number_text(round(duty, 3))} above its threshold"
            f" ({number_text(threshold)}), {number_text(round(decel_mps2, 2))} m/s² where the"
            f" rule's dwell assumes {number_text(BRAKE_DECEL_MPS2)} m/s² (duty"
            f" {number_text(BRAKE_DECEL_MPS2 / HYDRAULIC_FULL_DECEL_MPS2)} of"
            f" {number_text(HYDRAULIC_FULL_DECEL_MPS2)} m/s² at full duty): the robot could"
            " change direction still rolling",
            f"set interlocks.unknown_speed_brake_norm to {number_text(needed)} or more",
        )
    ]


def _noticed_text(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "is never noticed"
    return f"is noticed only after {number_text(round(seconds, 3))} s"


def _steering_monitor(robot: RobotConfig) -> list[Breach]:
    """The steering monitor sees a deviation that matters, and a stuck servo within the
    deadline: the slow-servo model's travel (full lock to full lock, less the tolerance) at
    `servo_speed_norm_per_s`, plus `steering_margin_s` (issue 41: a tolerance of 2, a margin of
    5 s or a crawling model switched it off)."""
    monitors = robot.monitors
    tolerance, speed = monitors.steering_tolerance_norm, monitors.servo_speed_norm_per_s
    margin_s, deadline_s = monitors.steering_margin_s, STUCK_SERVO_DEADLINE_S
    found = []
    if tolerance > STEERING_DEVIATION_NORM + 1e-9:
        found.append(
            Breach(
                STEERING.name,
                ("monitors.steering_tolerance_norm",),
                f"a servo stuck up to {number_text(tolerance)} off its command is never seen"
                f" (a deviation above {number_text(STEERING_DEVIATION_NORM)} must be)",
                f"set monitors.steering_tolerance_norm to {number_text(STEERING_DEVIATION_NORM)}"
                " or less",
            )
        )
    travel = FULL_TRAVEL_NORM - min(tolerance, STEERING_DEVIATION_NORM)
    noticed_s = travel / speed + margin_s
    if noticed_s <= deadline_s + 1e-9:
        return found
    options = []
    if margin_s < deadline_s:
        speed_needed = math.ceil(travel / (deadline_s - margin_s) * 100 - 1e-6) / 100
        if speed_needed <= POSITIVE_NORM_PER_S.high:  # the fastest model the loader takes
            needed = number_text(speed_needed)
            options.append(f"monitors.servo_speed_norm_per_s to {needed} or more")
    margin_max_s = (deadline_s - travel / speed) if math.isfinite(noticed_s) else -1.0
    margin_max_s = math.floor(margin_max_s * 1000 + 1e-6) / 1000
    if margin_max_s >= 0.0:
        options.append(f"monitors.steering_margin_s to {number_text(margin_max_s)} or less")
    if options:
        fix = "set " + ", or ".join(options)
    else:
        default = MonitorConfig()
        fix = (
            f"set monitors.servo_speed_norm_per_s to {number_text(default.servo_speed_norm_per_s)}"
            f" and monitors.steering_margin_s to {number_text(default.steering_margin_s)}"
        )
    found.append(
        Breach(
            STEERING.name,
            (
                "monitors.servo_speed_norm_per_s",
                "monitors.steering_margin_s",
                "monitors.steering_tolerance_norm",
            ),
            f"a servo stuck at full lock {_noticed_text(noticed_s)}"
            f" ({number_text(round(travel, 3))} of travel at {number_text(speed)} /s, plus"
            f" {number_text(margin_s)} s)",
            fix,
        )
    )
    return found


def _pressure_monitor(robot: RobotConfig) -> list[Breach]:
    """The pressure monitor watches the duties that matter, and flags a brake that builds no
    pressure within the deadline: its build-up time plus one decision period (a duty floor of 1.0
    or a 5 s build-up, both in range, switched it off or let seconds of braking do nothing)."""
    monitors = robot.monitors
    found = []
    if monitors.hydro_min_duty > HYDRO_FAILURE_DUTY + 1e-9:
        found.append(
            Breach(
                PRESSURE.name,
                ("monitors.hydro_min_duty",),
                f"a hydraulic brake that builds no pressure at a duty below"
                f" {number_text(monitors.hydro_min_duty)} is never noticed (one at"
                f" {number_text(HYDRO_FAILURE_DUTY)} or more must be)",
                f"set monitors.hydro_min_duty to {number_text(HYDRO_FAILURE_DUTY)} or less",
            )
        )
    period_s = decision_period_s(robot)
    noticed_s = monitors.hydro_response_s + period_s
    if noticed_s > HYDRO_FAILURE_DEADLINE_S + 1e-9:
        allowed_s = math.floor((HYDRO_FAILURE_DEADLINE_S - period_s) * 1000 + 1e-6) / 1000
        found.append(
            Breach(
                PRESSURE.name,
                ("monitors.hydro_response_s",),
                f"a hydraulic brake that builds no pressure is noticed only after"
                f" {number_text(round(noticed_s, 3))} s ({number_text(monitors.hydro_response_s)}"
                f" s of build-up plus a decision period of {number_text(round(period_s, 4))} s)",
                f"set monitors.hydro_response_s to {number_text(allowed_s)} or less",
            )
        )
    return found


def regen_decel_mps2(robot: RobotConfig) -> float:
    """The least deceleration the drive's regenerative brake gives this robot at full brake: the
    requirement's figure, scaled by the volts the file lets it have."""
    volts = min(robot.drive.limits.max_regen_volts, MOTOR_FULL_SCALE_VOLTS)
    return REGEN_DECEL_MPS2 * volts / MOTOR_FULL_SCALE_VOLTS


def robot_blind_spot_mps(robot: RobotConfig) -> float:
    """The fastest speed at which this robot's wheel sensor can die unnoticed (reads a stop)."""
    return blind_spot_mps(robot.interlocks, decision_period_s(robot))


def standstill_hold_s(robot: RobotConfig) -> float:
    """How long a controlled stop holds a standstill the sensor reads before power goes off:
    the time regeneration alone takes to stop a robot rolling at the blind spot's speed (a
    sensor dying there reads like a stop). Infinite without regeneration."""
    regen = regen_decel_mps2(robot)
    return robot_blind_spot_mps(robot) / regen if regen > 0.0 else math.inf


def _standstill_hold(robot: RobotConfig) -> list[Breach]:
    hold_s = standstill_hold_s(robot)
    if hold_s <= STANDSTILL_HOLD_MAX_S + 1e-9:
        return []
    blind_mps = robot_blind_spot_mps(robot)
    wanted = blind_mps / STANDSTILL_HOLD_MAX_S / REGEN_DECEL_MPS2 * MOTOR_FULL_SCALE_VOLTS
    volts = math.ceil(wanted * 100 - 1e-6) / 100
    fix = (
        f"set drive.max_regen_volts to {number_text(volts)} or more"
        if volts <= MOTOR_FULL_SCALE_VOLTS
        else "lower interlocks.speed_step_tolerance_mps or interlocks.speed_max_change_mps2"
    )
    held = "never" if math.isinf(hold_s) else f"in {number_text(round(hold_s, 3))} s"
    return [
        Breach(
            STANDSTILL_HOLD.name,
            ("drive.max_regen_volts", "interlocks.speed_step_tolerance_mps"),
            f"regeneration stops a robot that a dying wheel sensor hid (up to"
            f" {number_text(round(blind_mps, 3))} m/s) {held}: a controlled stop would keep a"
            f" standing robot's drive powered longer than {number_text(STANDSTILL_HOLD_MAX_S)} s",
            fix,
        )
    ]


def _controlled_stop(robot: RobotConfig) -> list[Breach]:
    """A controlled stop must not give up on a robot that regeneration alone is braking (issue
    41: 5 m/s² counted regeneration plus drag, 1.65 m/s², as "not slowing", and power went off
    at 0.66 m/s, with both mechanical brakes failed)."""
    wanted = robot.stop.controlled_min_decel_mps2
    regen = regen_decel_mps2(robot)
    if wanted <= regen + 1e-9:
        return []
    allowed = math.floor(regen * 100 + 1e-6) / 100
    volts = math.ceil(wanted / REGEN_DECEL_MPS2 * MOTOR_FULL_SCALE_VOLTS * 100 - 1e-6) / 100
    fix = f"set stop.controlled_min_decel_mps2 to {number_text(allowed)} or less"
    if volts <= MOTOR_FULL_SCALE_VOLTS:
        fix += f", or drive.max_regen_volts to {number_text(volts)} or more"
    return [
        Breach(
            CONTROLLED_STOP.name,
            ("stop.controlled_min_decel_mps2", "drive.max_regen_volts"),
            f"a controlled stop demanding {number_text(wanted)} m/s² gives up (power off) on a"
            f" robot that regeneration alone brakes at {number_text(round(regen, 3))} m/s²,"
            " throwing away the only brake left when both mechanical brakes fail",
            fix,
        )
    ]


def _blind_spot(robot: RobotConfig) -> list[Breach]:
    interlocks = robot.interlocks
    period_s = decision_period_s(robot)
    blind_mps = blind_spot_mps(interlocks, period_s)
    if blind_mps <= BLIND_SPOT_MPS + 1e-9:
        return []
    tolerance = max(BLIND_SPOT_MPS - interlocks.speed_max_change_mps2 * period_s, 0.0)
    change = max((BLIND_SPOT_MPS - interlocks.speed_step_tolerance_mps) / period_s, 0.0)
    return [
        Breach(
            BLIND_SPOT.name,
            ("interlocks.speed_step_tolerance_mps", "interlocks.speed_max_change_mps2"),
            f"a wheel sensor dying at up to {number_text(round(blind_mps, 3))} m/s reads like a"
            " stop: the interlock could reverse at that speed",
            f"set interlocks.speed_step_tolerance_mps to {number_text(round(tolerance, 3))} or"
            f" less, or interlocks.speed_max_change_mps2 to {number_text(round(change, 1))} or"
            " less",
        )
    ]


def _hardest_stop(robot: RobotConfig) -> list[Breach]:
    """The speed check must pass the robot's own hardest stop (row 73, found by `bywire verify
    --draw-robots --seed 4`, file 9): a change between two decisions Δ apart (0 to a decision
    period) may be the hardest stop's over Δ plus one sample, and the check allows the
    tolerance plus the largest change over Δ. Linear in Δ: both ends are checked."""
    interlocks = robot.interlocks
    period_s = decision_period_s(robot)
    tolerance = interlocks.speed_step_tolerance_mps
    change = interlocks.speed_max_change_mps2
    at_once = HARDEST_STOP_DECEL_MPS2 * WHEEL_SAMPLE_S
    over_a_period = HARDEST_STOP_DECEL_MPS2 * (period_s + WHEEL_SAMPLE_S)
    if tolerance >= at_once - 1e-9 and tolerance + change * period_s >= over_a_period - 1e-9:
        return []
    needed = max(at_once, over_a_period - change * period_s)
    fix = f"set interlocks.speed_step_tolerance_mps to {number_text(_up(needed, 3))} or more"
    if tolerance >= at_once - 1e-9:
        wanted = (over_a_period - tolerance) / period_s
        fix += f", or interlocks.speed_max_change_mps2 to {number_text(_up(wanted, 1))} or more"
    return [
        Breach(
            HARDEST_STOP.name,
            ("interlocks.speed_step_tolerance_mps", "interlocks.speed_max_change_mps2"),
            f"the robot's hardest stop ({number_text(HARDEST_STOP_DECEL_MPS2)} m/s², every brake)"
            f" changes a reading by up to {number_text(round(at_once, 3))} m/s between two"
            f" decisions a moment apart and {number_text(round(over_a_period, 3))} m/s between"
            f" two a decision period ({number_text(round(period_s, 4))} s) apart; the check"
            f" allows {number_text(tolerance)} m/s and {number_text(change)} m/s² of the time"
            " between them, so it takes a sound wheel sensor for a dying one, and a controlled"
            " stop loses the speed that ends it (the drive stays powered at standstill)",
            fix,
        )
    ]


def _start_curve(throttle_norm: float, top_speed_mps: float) -> tuple[float, float] | None:
    """The class's weakest start at `throttle_norm` on the flat, dv/dt = c − k·v: its net
    acceleration from standstill c (m/s²) and the rate k (1/s) at which the fading drive gives
    it up; None when the drag outweighs the drive. The drive, `DRIVE_ACCEL_MPS2` × throttle,
    fades linearly with the speed to nothing where full throttle only holds `top_speed_mps`
    against the drag: c = a·u − d, k = a·u/F."""
    fade_mps = top_speed_mps / (1.0 - ROLLING_DRAG_MPS2 / DRIVE_ACCEL_MPS2)
    net_mps2 = DRIVE_ACCEL_MPS2 * throttle_norm - ROLLING_DRAG_MPS2
    if net_mps2 <= 0.0:
        return None
    return net_mps2, DRIVE_ACCEL_MPS2 * throttle_norm / fade_mps


def start_s(throttle_norm: float, speed_mps: float, top_speed_mps: float) -> float:
    """How long the class's weakest start at `throttle_norm` takes from standstill to more than
    `speed_mps` on the flat (`math.inf`: never): v(t) = (c/k)(1 − e^(−kt)) (`_start_curve`)."""
    curve = _start_curve(throttle_norm, top_speed_mps)
    if curve is None:
        return math.inf
    net_mps2, rate_per_s = curve
    reached = speed_mps * rate_per_s / net_mps2
    return math.inf if reached >= 1.0 else -math.log1p(-reached) / rate_per_s


def _start_speed_mps(throttle_norm: float, top_speed_mps: float, after_s: float) -> float:
    """The speed the class's weakest start at `throttle_norm` has reached after `after_s`
    (`start_s`'s inverse)."""
    curve = _start_curve(throttle_norm, top_speed_mps)
    if curve is None or after_s <= 0.0:
        return 0.0
    net_mps2, rate_per_s = curve
    return net_mps2 / rate_per_s * -math.expm1(-rate_per_s * after_s)


def _least_start_throttle(speed_mps: float, top_speed_mps: float, within_s: float) -> float | None:
    """The least throttle whose start passes `speed_mps` within `within_s` (None: not even
    full throttle's); `start_s` falls as the throttle rises."""
    if within_s <= 0.0 or start_s(1.0, speed_mps, top_speed_mps) > within_s:
        return None
    low, high = ROLLING_DRAG_MPS2 / DRIVE_ACCEL_MPS2, 1.0
    for _ in range(60):
        middle = (low + high) / 2.0
        low, high = (
            (middle, high)
            if start_s(middle, speed_mps, top_speed_mps) > within_s
            else (low, middle)
        )
    return high


def _start(robot: RobotConfig) -> list[Breach]:
    """A start is no stuck sensor (row 81, found by `bywire verify --draw-robots --seed 8`, file
    1): the stuck check flags a wheel sensor that reads standstill while the applied throttle is
    at `speed_stuck_throttle_norm` or more for longer than `speed_stuck_s`. A sound sensor reads
    standstill until the robot passes `standstill_speed_mps`; the class's weakest start at the
    check's throttle must get there within the dwell, less a reading's age and a decision
    period (the reading that shows it is read at the next decision). The throttle drives the
    motors in proportion to `drive.max_throttle_volts` of their full scale. On the flat:
    uphill, a throttle that balances the grade stands still (docs/SAFETY.md, what is not
    covered)."""
    interlocks = robot.interlocks
    throttle = interlocks.speed_stuck_throttle_norm
    dwell_s = interlocks.speed_stuck_s
    standstill_mps = interlocks.standstill_speed_mps
    volts = min(robot.drive.limits.max_throttle_volts, MOTOR_FULL_SCALE_VOLTS)
    scale = volts / MOTOR_FULL_SCALE_VOLTS  # of the drive's full scale, at throttle 1
    top_mps = min(top_speed_mps(robot), REVERSE_TOP_SPEED_MPS)
    slack_s = WHEEL_SAMPLE_S + decision_period_s(robot)
    needed_s = start_s(throttle * scale, standstill_mps, top_mps) + slack_s
    if needed_s <= dwell_s + 1e-9:
        return []
    keys: tuple[str, ...] = ("interlocks.speed_stuck_throttle_norm", "interlocks.speed_stuck_s")
    if scale < 1.0:
        keys += ("drive.max_throttle_volts",)
    fixes = []
    if needed_s <= DWELL_S.high:
        fixes.append(f"interlocks.speed_stuck_s to {number_text(_up(needed_s, 3))} or more")
    least = _least_start_throttle(standstill_mps, top_mps, dwell_s - slack_s)
    if least is not None and least <= scale * (1.0 - 1e-3):
        fixes.append(
            f"interlocks.speed_stuck_throttle_norm to {number_text(_up(least / scale, 3))} or more"
        )
    if least is not None and scale < 1.0 and throttle > 0.0 and least <= throttle:
        least_volts = _up(least / throttle * MOTOR_FULL_SCALE_VOLTS, 3)
        fixes.append(f"drive.max_throttle_volts to {number_text(least_volts)} or more")
    most_mps = _down(_start_speed_mps(throttle * scale, top_mps, dwell_s - slack_s), 3)
    if most_mps > 0.0:
        fixes.append(f"interlocks.standstill_speed_mps to {number_text(most_mps)} or less")
    if not fixes:  # no one key does it: the default throttle (else full), and its dwell
        pair = max(throttle, InterlockConfig().speed_stuck_throttle_norm)
        if not math.isfinite(start_s(pair * scale, standstill_mps, top_mps)):
            pair = 1.0
        pair_s = start_s(pair * scale, standstill_mps, top_mps) + slack_s
        if pair_s <= DWELL_S.high:
            fixes.append(
                f"interlocks.speed_stuck_throttle_norm to {number_text(pair)} and"
                f" interlocks.speed_stuck_s to {number_text(_up(pair_s, 3))} or more"
            )
    moves = math.isfinite(start_s(throttle * scale, 0.0, top_mps))
    how = (
        f"reads standstill ({number_text(standstill_mps)} m/s or less) for"
        f" {number_text(_up(needed_s, 3))} s, a reading's age and a decision period included"
        if math.isfinite(needed_s)
        else (f"never passes {number_text(standstill_mps)} m/s" if moves else "never moves")
    )
    at = f"{number_text(throttle)}" + (f" of {number_text(volts)} V" if scale < 1.0 else "")
    return [
        Breach(
            START.name,
            keys,
            f"at the stuck check's throttle ({at}) the class's weakest start on the flat"
            f" ({number_text(DRIVE_ACCEL_MPS2)} m/s² at full scale,"
            f" {number_text(MOTOR_FULL_SCALE_VOLTS)} V, against"
            f" {number_text(ROLLING_DRAG_MPS2)} m/s² of drag) {how}; the check allows"
            f" {number_text(dwell_s)} s, so it takes a sound wheel sensor for a stuck one, and a"
            " controlled stop loses the speed that ends it (the drive stays powered at"
            " standstill)",
            "set " + ", or ".join(fixes) if fixes else "lower interlocks.standstill_speed_mps",
        )
    ]


def _down(value: float, digits: int) -> float:
    """`value` rounded down to `digits` decimals (a nearest safe value that is safe)."""
    scale = 10.0**digits
    return math.floor(value * scale + 1e-6) / scale


def _up(value: float, digits: int) -> float:
    """`value` rounded up to `digits` decimals (a nearest safe value that is safe)."""
    scale = 10.0**digits
    return math.ceil(value * scale - 1e-6) / scale


def _movement_timeout(robot: RobotConfig) -> tuple[str, float]:
    """MovementCommand's timeout and the key that sets it (its own, else the section's)."""
    timeouts = robot.timeouts
    movement_s = timeouts.can_timeout_s(MovementCommand.__name__)
    if movement_s == timeouts.can_command_timeout_s:
        return "timeouts.can_command_timeout_s", movement_s
    return f"timeouts.can_message_timeout_s.{MovementCommand.__name__}", movement_s


def _stall(robot: RobotConfig) -> list[Breach]:
    timeouts = robot.timeouts
    watchdog_s = timeouts.watchdog_s
    movement_key, movement_s = _movement_timeout(robot)
    found = []
    for key, timeout_s, what in (
        ("timeouts.rc_timeout_s", timeouts.rc_timeout_s, "a lost RC link"),
        (movement_key, movement_s, "a silent computer"),
    ):
        if timeout_s > watchdog_s:
            found.append(
                Breach(
                    STALL.name,
                    (key, "timeouts.watchdog_s"),
                    f"{key} = {number_text(timeout_s)} s is longer than the watchdog's"
                    f" {number_text(watchdog_s)} s: {what} drives on longer than a stalled loop"
                    " would",
                    f"set {key} to {number_text(watchdog_s)} or less",
                )
            )
    return found


def _debounce(robot: RobotConfig) -> list[Breach]:
    frames, frame_s = robot.supervisor.debounce_frames, robot.sim.rc_frame_period_s
    debounce_s, timeout_s = frames * frame_s, robot.timeouts.rc_timeout_s
    if debounce_s < timeout_s:
        return []
    return [
        Breach(
            SWITCH.name,
            ("supervisor.debounce_frames", "sim.rc_frame_period_s", "timeouts.rc_timeout_s"),
            f"{frames} frames of {number_text(frame_s)} s = {number_text(debounce_s)} s of"
            f" debounce is not shorter than timeouts.rc_timeout_s = {number_text(timeout_s)} s:"
            " a switch position would be judged on frames older than the link is trusted",
            f"set supervisor.debounce_frames to {max(math.ceil(timeout_s / frame_s) - 1, 2)} or"
            " less",
        )
    ]


@dataclass(frozen=True, slots=True)
class StopPromise:
    """One stop deadline `docs/SAFETY.md` promises (issue 41: budgets come from deadlines): from
    `event` to the spring brake's line engaged (and the enable line low, where the stop is
    category 0), at most `detection_s` (the time the event takes to reach the controller: the
    frame that carries it, the input's timeout) plus `response_s`, the controller's share as
    the requirement states it. A robot file may declare a longer share
    (`[timeouts] stop_response_s`, for a test bench that cannot keep the robot's): it is then
    held to that at load, shown by `bywire config check`, and still judged at `response_s` by
    `bywire verify`'s oracle.

    The controller keeps it by the rule `response_needed_s` states, for every pattern of work
    within the budgets `[timeouts]` gives: a stop is decided in the first pass that begins after
    it is seen, and that pass writes the e-brake's line and the enable line first, before
    anything slow (the schedule table's order). A frame wakes the loop when it has arrived
    (`wakes`), so what it waits for is its wire time and the rest of a pass in flight; a timeout
    is seen at a tick, the next one or the end of a pass in flight, whichever is later."""

    name: str
    event: str
    detection: str
    detection_s: Callable[[RobotConfig], float]
    response_s: float
    wakes: bool
    wire_s: float = 0.0

    def allowed_s(self, robot: RobotConfig) -> float:
        """The controller's share `robot` is held to: the requirement's, or the longer one
        the file declares."""
        return max(self.response_s, robot.timeouts.stop_response_s)

    def deadline_s(self, robot: RobotConfig) -> float:
        return self.detection_s(robot) + self.allowed_s(robot)

    def response_needed_s(self, robot: RobotConfig) -> float:
        """The longest the controller may take to act under `robot`'s budgets and rates."""
        pass_s = robot.timeouts.pass_budget_s
        if self.wakes:
            return self.wire_s + pass_s
        return max(decision_period_s(robot), pass_s)

    def most_pass_budget_s(self, robot: RobotConfig | None = None) -> float:
        """The largest pass budget that keeps this promise (given a fast enough tick): the
        requirement's, or `robot`'s declared one."""
        allowed_s = self.response_s if robot is None else self.allowed_s(robot)
        return allowed_s - self.wire_s


def _movement_timeout_s(robot: RobotConfig) -> float:
    return robot.timeouts.can_timeout_s(MovementCommand.__name__)


OPERATOR_STOP = StopPromise(
    "the operator's STOP",
    "the operator's switch moves to STOP",
    "the IBUS frame that carries it",
    lambda _robot: ibus.FRAME_PERIOD_S,
    STOP_RESPONSE_S,
    wakes=True,
    wire_s=IBUS_WIRE_S,
)
RC_LOSS = StopPromise(
    "an RC loss",
    "the RC link's last frame arrives",
    "timeouts.rc_timeout_s",
    lambda robot: robot.timeouts.rc_timeout_s,
    MAX_CONTROL_PERIOD_S,
    wakes=False,
)
CAN_LOSS = StopPromise(
    "a CAN loss",
    "the computer's last movement command arrives, in CAN mode",
    "MovementCommand's timeout",
    _movement_timeout_s,
    MAX_CONTROL_PERIOD_S,
    wakes=False,
)
STOP_PROMISES: tuple[StopPromise, ...] = (OPERATOR_STOP, RC_LOSS, CAN_LOSS)
"""Every stop deadline `docs/SAFETY.md` promises, stated once: the load check below, the
oracle of `bywire verify` and the tests judge with these."""
MOST_PASS_BUDGET_S = min(promise.most_pass_budget_s() for promise in STOP_PROMISES)
"""The largest pass budget that keeps every promise as the requirement states it."""
MOST_DAC_TRANSFER_BUDGET_S = MOST_PASS_BUDGET_S / DAC_TRANSFERS_PER_PASS
"""The largest DAC transfer budget that keeps them: a pass's transfers within it (what
`bywire verify` bounds a file's budget by, whatever it declares)."""


def promise_lines(robot: RobotConfig) -> list[str]:
    """Each stop promise `robot` is held to, one line each (`bywire config check` shows them),
    naming a share longer than the requirement's."""
    lines = []
    for promise in STOP_PROMISES:
        allowed_s = promise.allowed_s(robot)
        declared = (
            f" (declared by timeouts.stop_response_s; the requirement is"
            f" {number_text(promise.response_s)} s)"
            if allowed_s > promise.response_s
            else ""
        )
        lines.append(
            f"{promise.event} -> the spring brake within {promise.detection} +"
            f" {number_text(allowed_s)} s = {number_text(round(promise.deadline_s(robot), 4))}"
            f" s{declared}"
        )
    return lines


def _floor_ms(seconds: float) -> float:
    """`seconds` rounded down to 0.1 ms: a suggestion that keeps the bound it comes from."""
    return math.floor(seconds * 10_000 + 1e-9) / 10_000


def _stop_promises(robot: RobotConfig) -> list[Breach]:
    found = []
    budgets = robot.timeouts
    most_pass_s = min(promise.most_pass_budget_s(robot) for promise in STOP_PROMISES)
    for promise in STOP_PROMISES:
        needed_s = promise.response_needed_s(robot)
        if needed_s <= promise.allowed_s(robot) + 1e-12 or budgets.pass_budget_s <= (
            promise.most_pass_budget_s(robot) + 1e-12
        ):
            continue  # kept, or broken by the tick alone (the input-loss deadline says so)
        found.append(
            Breach(
                STOP_PROMISE.name,
                ("timeouts.pass_budget_s",),
                f"{promise.event}: the stop may reach the brakes"
                f" {number_text(round(promise.detection_s(robot) + needed_s, 4))} s after it,"
                f" past the {number_text(round(promise.deadline_s(robot), 4))} s promised"
                f" ({promise.detection} + {number_text(promise.allowed_s(robot))} s), when a pass"
                f" within its {number_text(budgets.pass_budget_s)} s budget is under way",
                f"set timeouts.pass_budget_s to {number_text(_floor_ms(most_pass_s))} or less",
            )
        )
        break  # one pass budget for every promise: the tightest suggestion says it all
    # Held to the pass budget the file may have: one refusal names every budget to change.
    pass_s = min(budgets.pass_budget_s, most_pass_s)
    transfers_s = DAC_TRANSFERS_PER_PASS * budgets.dac_transfer_budget_s
    if transfers_s > pass_s + 1e-12:
        found.append(
            Breach(
                STOP_PROMISE.name,
                ("timeouts.dac_transfer_budget_s", "timeouts.pass_budget_s"),
                f"a pass writes {DAC_TRANSFERS_PER_PASS} DAC transfers, each within its"
                f" {number_text(budgets.dac_transfer_budget_s)} s budget: together"
                f" {number_text(round(transfers_s, 6))} s, more than a pass may take"
                f" ({number_text(round(pass_s, 6))} s), so transfers no budget calls slow hold"
                " a stop back",
                f"set timeouts.dac_transfer_budget_s to"
                f" {number_text(_floor_ms(pass_s / DAC_TRANSFERS_PER_PASS))} or less",
            )
        )
    if budgets.write_budget_s > pass_s + 1e-12:
        found.append(
            Breach(
                STOP_PROMISE.name,
                ("timeouts.write_budget_s", "timeouts.pass_budget_s"),
                f"one port write within its {number_text(budgets.write_budget_s)} s budget"
                f" would be longer than a pass may take ({number_text(round(pass_s, 6))} s)",
                f"set timeouts.write_budget_s to {number_text(_floor_ms(pass_s))} or less",
            )
        )
    return found


def pairing_frames() -> tuple[int, int]:
    """How many frames may end between a command frame's last bit and its cryptographic PDU's
    last bit, the PDU included, and the bits of the longest of them: the period's other
    commands (a lower id wins arbitration, and every command's id is below every PDU's), one
    frame of another node, and the PDU itself; (commands + 1) frames."""
    from bywire.protocol import dbc  # noqa: PLC0415 (cantools only when a file is checked)
    from bywire.protocol.secoc import AUTH_PDU_BYTES  # noqa: PLC0415

    commands = dbc.command_ids()
    longest_bytes = max(AUTH_PDU_BYTES, *(dbc.length_bytes(frame) for frame in commands))
    return len(commands) - 1 + FOREIGN_FRAMES_BETWEEN + 1, frame_bits(longest_bytes)


def pairing_window_needed_s(bitrate_bps: int) -> float:
    """The least pairing window in which every command frame of a period meets its cryptographic
    PDU at `bitrate_bps` (`pairing_frames`)."""
    frames, bits = pairing_frames()
    return frames * bits / bitrate_bps


def _pairing(robot: RobotConfig) -> list[Breach]:
    """Authenticated commands pair on this bus (issue 41: a window of 0.5 ms at 500 kbit/s
    rejected every command, a remote stop in RC mode among them; 0.8 ms lost a third)."""
    window_s, bitrate_bps = robot.security.pairing_window_s, robot.can.bitrate_bps
    needed_s = pairing_window_needed_s(bitrate_bps)
    if window_s >= needed_s - 1e-12:
        return []
    frames, bits = pairing_frames()
    suggested_s = math.ceil(needed_s * 1e5 - 1e-6) / 1e5
    if suggested_s <= PAIRING_WINDOW_S.high:
        fix = f"set security.pairing_window_s to {number_text(suggested_s)} or more"
    else:
        least_bps = math.ceil(frames * bits / PAIRING_WINDOW_S.high)
        fix = (
            f"no legal window is that long (at most {number_text(PAIRING_WINDOW_S.high)} s):"
            f" set can.bitrate_bps to {least_bps} or more"
        )
    return [
        Breach(
            PAIRING.name,
            ("security.pairing_window_s", "can.bitrate_bps"),
            f"a command frame's cryptographic PDU may end up to {frames} frames of {bits} bits"
            f" after it ({number_text(round(needed_s, 7))} s at {bitrate_bps} bit/s):"
            f" a window of {number_text(window_s)} s rejects authenticated commands, the stop"
            " among them",
            fix,
        )
    ]


INPUT_LOSS = Deadline(
    "input loss",
    f"a lost input reaches safe outputs within its timeout plus"
    f" {number_text(MAX_CONTROL_PERIOD_S)} s",
    _input_loss,
)
DAC_FAILURE = Deadline(
    "a failing DAC",
    f"failing DAC writes reach safe outputs within {number_text(DAC_FAILURE_DEADLINE_S)} s",
    _dac_failure,
)
NO_REVERSAL = Deadline(
    "no reversal at speed",
    f"the direction never changes above {number_text(STANDSTILL_LIMIT_MPS)} m/s, with or"
    f" without a speed sensor (from up to {number_text(TOP_SPEED_MPS)} m/s)",
    _no_reversal,
)
BLIND_SPOT = Deadline(
    "a dead wheel sensor is noticed",
    f"a wheel sensor that dies above {number_text(BLIND_SPOT_MPS)} m/s is noticed",
    _blind_spot,
)
HARDEST_STOP = Deadline(
    "a hard stop is no sensor fault",
    f"the wheel-speed check takes the robot's hardest stop"
    f" ({number_text(HARDEST_STOP_DECEL_MPS2)} m/s²) for a stop, with readings up to"
    f" {number_text(WHEEL_SAMPLE_S)} s old",
    _hardest_stop,
)
START = Deadline(
    "a start is no stuck sensor",
    f"the wheel-speed check's stuck test takes the robot's weakest start on the flat"
    f" ({number_text(DRIVE_ACCEL_MPS2)} m/s² at full throttle against"
    f" {number_text(ROLLING_DRAG_MPS2)} m/s² of drag) for a start",
    _start,
)
STALL = Deadline(
    "a stall is no longer than a loss",
    "no input drives on longer than a stalled loop would (the watchdog)",
    _stall,
)
SWITCH = Deadline(
    "a switch is judged on fresh frames",
    "the mode switch's debounce is shorter than the RC timeout",
    _debounce,
)
STEERING = Deadline(
    "a stuck servo is noticed",
    f"a servo stuck more than {number_text(STEERING_DEVIATION_NORM)} off its command, anywhere on"
    f" its travel, is noticed within {number_text(STUCK_SERVO_DEADLINE_S)} s",
    _steering_monitor,
)
PRESSURE = Deadline(
    "a failed hydraulic brake is noticed",
    f"a hydraulic brake that builds no pressure at a duty of {number_text(HYDRO_FAILURE_DUTY)}"
    f" or more is noticed within {number_text(HYDRO_FAILURE_DEADLINE_S)} s (with a pressure"
    " sensor fitted)",
    _pressure_monitor,
)
CONTROLLED_STOP = Deadline(
    "a controlled stop keeps regeneration",
    f"a controlled stop never removes power from a robot regeneration alone brakes"
    f" ({number_text(REGEN_DECEL_MPS2)} m/s² at {number_text(MOTOR_FULL_SCALE_VOLTS)} V)",
    _controlled_stop,
)
STANDSTILL_HOLD = Deadline(
    "a standstill is held only briefly",
    f"a controlled stop holds a standstill (regeneration stopping a robot a dying wheel sensor"
    f" hid) for at most {number_text(STANDSTILL_HOLD_MAX_S)} s",
    _standstill_hold,
)
STOP_PROMISE = Deadline(
    "a stop within its promise",
    "every stop deadline of `STOP_PROMISES` holds whatever the work of a pass, within the"
    " budgets: a pass within its budget, and its DAC transfers and port writes within theirs",
    _stop_promises,
)
PAIRING = Deadline(
    "an authenticated command pairs",
    "a command frame meets its cryptographic PDU within the pairing window, with the period's"
    " other commands and one frame of another node between them on the bus",
    _pairing,
)
DEADLINES: tuple[Deadline, ...] = (
    INPUT_LOSS,
    DAC_FAILURE,
    NO_REVERSAL,
    BLIND_SPOT,
    HARDEST_STOP,
    START,
    STALL,
    SWITCH,
    STEERING,
    CONTROLLED_STOP,
    STANDSTILL_HOLD,
    STOP_PROMISE,
    PRESSURE,
    PAIRING,
)
"""Every deadline a robot file must keep, in the order of `docs/SAFETY.md`."""


def breaches(robot: RobotConfig) -> list[Breach]:
    """Every deadline `robot` breaks, each with the nearest safe values."""
    return [breach for deadline in DEADLINES for breach in deadline.check(robot)]


@dataclass(frozen=True, slots=True)
class LossDistance:
    """How far a lost input (or a stalled loop) lets the robot drive on at its top speed before
    the stop begins: what a file's timeout buys (issue 41)."""

    key: str
    what: str
    timeout_s: float
    before_stop_s: float
    top_speed_mps: float

    @property
    def distance_m(self) -> float:
        return self.before_stop_s * self.top_speed_mps

    def __str__(self) -> str:
        return (
            f"{self.what} ({self.key} = {number_text(self.timeout_s)} s): the stop begins within"
            f" {number_text(round(self.before_stop_s, 3))} s, after up to"
            f" {number_text(round(self.distance_m, 2))} m at"
            f" {number_text(self.top_speed_mps)} m/s"
        )


def top_speed_mps(robot: RobotConfig) -> float:
    """The robot's top speed: the simulated robot's own, else the class's (`TOP_SPEED_MPS`)."""
    return robot.sim.top_speed_mps if robot.backend == "sim" else TOP_SPEED_MPS


def loss_distances(robot: RobotConfig) -> list[LossDistance]:
    """For each input timeout that moves the robot and for the watchdog: the time and the distance
    at top speed before the stop begins. An input loss is acted on within its timeout plus one
    decision period (`INPUT_LOSS`); a stalled loop when the watchdog runs out. No bound is put on
    them beyond the loader's ranges and `STALL`: slow test rigs need long timeouts; a robot file
    is shown what its own cost (`bywire config check`, `bywire verify`)."""
    timeouts = robot.timeouts
    period_s = decision_period_s(robot)
    movement_key, movement_s = _movement_timeout(robot)
    speed = top_speed_mps(robot)
    return [
        LossDistance(
            "timeouts.rc_timeout_s",
            "an unplugged RC receiver",
            timeouts.rc_timeout_s,
            timeouts.rc_timeout_s + period_s,
            speed,
        ),
        LossDistance(
            movement_key, "a silent computer (CAN mode)", movement_s, movement_s + period_s, speed
        ),
        LossDistance(
            "timeouts.watchdog_s",
            "a stalled control loop",
            timeouts.watchdog_s,
            timeouts.watchdog_s,
            speed,
        ),
    ]


def loss_rows(robot: RobotConfig) -> list[dict[str, object]]:
    """`loss_distances` as JSON rows (`bywire config check --json`, `bywire verify --json`)."""
    return [
        {
            "key": loss.key,
            "what": loss.what,
            "timeout_s": loss.timeout_s,
            "before_stop_s": round(loss.before_stop_s, 6),
            "top_speed_mps": loss.top_speed_mps,
            "distance_m": round(loss.distance_m, 6),
        }
        for loss in loss_distances(robot)
    ]
