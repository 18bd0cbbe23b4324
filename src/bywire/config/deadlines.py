"""The physical deadlines a robot file must keep, stated once, and the constraints they put on
its keys (R-CONFIG-SAFETY).

Each key is range-checked on its own by the loader; these rows are what several keys must do
together. Each states a deadline of `docs/SAFETY.md` with the requirement's own figures (never
the file's), and derives from it what the file's numbers must satisfy; a file that breaks one is
refused at load (exit 2), naming the deadline and the nearest safe values. `bywire verify`'s
oracle judges with the same requirement figures, so an unsafe file cannot also set its judge's
deadlines (issue 30: every task at 1 Hz, both dwells at 0 on a robot without a wheel sensor, or
the loosest speed check each switched a safety function off while every key was in range).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from bywire.config.reader import number_text
from bywire.config.tree import RobotConfig
from bywire.control.dac_health import DAC_FAILURE_LIMIT, DAC_TRANSFERS_PER_PASS
from bywire.control.stop import STANDSTILL_LIMIT_MPS
from bywire.model import MovementCommand
from bywire.protocol import ibus

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
BLIND_SPOT_MPS = 0.5
"""A wheel sensor that dies faster than this is noticed (docs/SAFETY.md row 27)."""
STOP_RESPONSE_S = 0.010
"""One control period: the most a stop carried by a frame may take from the frame's period to
the brakes (docs/SAFETY.md: "the frame that carries the change, plus one control period")."""
IBUS_WIRE_S = ibus.FRAME_LENGTH * 10 / ibus.BAUD_RATE
"""An IBUS frame's time on the wire (8N1: 10 bits a byte): the frame period counts from when a
frame begins, the controller has it when it ends (2.8 ms)."""


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


def _decision_period_s(robot: RobotConfig) -> float:
    """How long a decision may wait: one period of the fastest task (every due task decides)."""
    return 1.0 / max(rate for _, rate in robot.tasks.rates_hz)


def _input_loss(robot: RobotConfig) -> list[Breach]:
    period_s = _decision_period_s(robot)
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
    threshold = robot.hydrobrake.threshold_norm
    if interlocks.unknown_speed_brake_norm < threshold:
        found.append(
            Breach(
                NO_REVERSAL.name,
                ("interlocks.unknown_speed_brake_norm", "hydrobrake.threshold_norm"),
                f"the brake the no-sensor rule demands"
                f" ({number_text(interlocks.unknown_speed_brake_norm)}) is below the hydraulic"
                f" brake's threshold ({number_text(threshold)}): the robot would change"
                " direction without the brake ever applied",
                f"set interlocks.unknown_speed_brake_norm to {number_text(threshold)} or more",
            )
        )
    return found


def _blind_spot(robot: RobotConfig) -> list[Breach]:
    interlocks = robot.interlocks
    period_s = _decision_period_s(robot)
    blind_mps = interlocks.speed_step_tolerance_mps + interlocks.speed_max_change_mps2 * period_s
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


def _stall(robot: RobotConfig) -> list[Breach]:
    timeouts = robot.timeouts
    watchdog_s = timeouts.watchdog_s
    movement_s = timeouts.can_timeout_s(MovementCommand.__name__)
    movement_key = (
        "timeouts.can_command_timeout_s"
        if movement_s == timeouts.can_command_timeout_s
        else f"timeouts.can_message_timeout_s.{MovementCommand.__name__}"
    )
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
        return max(_decision_period_s(robot), pass_s)

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
STOP_PROMISE = Deadline(
    "a stop within its promise",
    "every stop deadline of `STOP_PROMISES` holds whatever the work of a pass, within the"
    " budgets: a pass within its budget, and its DAC transfers and port writes within theirs",
    _stop_promises,
)
DEADLINES: tuple[Deadline, ...] = (
    INPUT_LOSS,
    DAC_FAILURE,
    NO_REVERSAL,
    BLIND_SPOT,
    STALL,
    SWITCH,
    STOP_PROMISE,
)
"""Every deadline a robot file must keep, in the order of `docs/SAFETY.md`."""


def breaches(robot: RobotConfig) -> list[Breach]:
    """Every deadline `robot` breaks, each with the nearest safe values."""
    return [breach for deadline in DEADLINES for breach in deadline.check(robot)]
