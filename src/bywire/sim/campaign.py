"""A fault campaign: a sequence of timed actions on the simulated robot, judged by the oracle.

Each step waits its delay, then does one thing an operator, the higher-level computer or the
world can do (`VOCABULARY`): move a stick or a switch (or arm deliberately), bounce the switch,
lose, garble or fake the RC link, send, corrupt or stop CAN commands, pull the CAN cable or flood
the bus, ask for a remote stop or a re-enable, let a second node send on the computer's id, make
DAC writes fail or hang, kill the wheel-speed sensor, break a brake or the steering.

A campaign is compiled into a scenario (`compile_steps`): the same events `bywire sim
--scenario` plays, so any campaign can be written to a TOML file and replayed exactly. The real
controller runs it on virtual time with its watchdog on the simulated clock; an `OracleWitness`
tells the `HazardOracle` what each event did, and the oracle checks the hardware after every pass
of the loop. Which rows of the supervisor's transition table the campaign took is recorded too.
"""

from __future__ import annotations

import contextlib
import heapq
import logging
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

from bywire.config import RobotConfig, default_sim_config
from bywire.control.supervisor import SupervisorState
from bywire.control.supervisor_check import transition_labels
from bywire.hal.sim.clock import VirtualClock
from bywire.model import ControlMode, Gear
from bywire.runtime.watchdog import POLL_S as WATCHDOG_POLL_S
from bywire.sim.oracle import CAN_ONLY, CAN_SILENT, SLOW_TRANSFER_S, HazardOracle, OracleTiming
from bywire.sim.runner import SimRun
from bywire.sim.scenario import Event, Scenario

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP
ARM_HOLD_S = 0.060  # how long `arm` holds the switch at STOP: eight frames
HANDOVER_LEAD_S = 0.045  # the computer's new set-point is on the bus before the switch moves
RE_ENABLE_RISE_S = 0.045  # a re-enable: 0 in the frames now, 1 two command periods later
IMPOSTOR_PERIOD_S = 0.020  # the impostor sends one frame per command period
STALL_OF_WATCHDOG = {"short": 0.25, "long": 1.5}  # a stall inside a DAC write, in watchdogs
TAIL_S = 0.5

VOCABULARY: dict[str, Sequence[object]] = {
    # what the operator does
    "arm": (RC, RC, CAN),  # switch to STOP, hold it, the source at zero, switch over
    "flick": (0.005, 0.02, 0.05, 0.1),  # through STOP and straight back after this long
    "handover": (0.0, 0.2, 0.6),  # to the other source, which asks for this throttle
    "rc_throttle": (0.0, 0.0, 0.3, 0.8, -0.6, -1.0),  # below zero: the brake
    "can_throttle": (0.0, 0.0, 0.2, 0.6),
    # sticks, switches and set-points
    "switch": tuple(ControlMode),
    "rc_gear": tuple(Gear),
    "rc_steer": (-0.6, 0.0, 0.5),
    "rc_lights": (False, True),
    "can_gear": tuple(Gear),
    "can_steer": (-0.5, 0.0, 0.5),
    "can_brake": (0.0, 0.0, 0.5, 1.0),
    "can_lights": (False, True),
    # the RC link
    "chatter": range(4, 41),  # of the next frames every other one reads STOP
    "rc_link": (False, True),
    "rc_failsafe": (False, True),
    "rc_implausible": range(1, 4),
    "rc_corrupt": (1, 3, 10),  # frames with a damaged byte
    "rc_garbage": (10, 40, 200),  # random bytes on the line
    # the CAN link
    "can_link": (False, True),  # the computer silent, or sending again
    "can_repeat": range(1, 5),  # movement frames repeating their counter
    "can_corrupt": ("crc", "length", "range"),  # the next three movement frames damaged
    "can_cable": (False, True),  # unplugged, or plugged again
    "can_flood": (0.0, 0.5, 1.0),  # other nodes' share of the bus (0: they stop)
    "remote_stop": (False, True),
    "re_enable": (None,),
    "impostor": range(5, 41),  # frames a second node sends on the computer's movement id
    "impostor_control": range(5, 41),  # …on its control id (an idle teleop: no stop, no enable)
    "impostor_lights": range(5, 41),  # …on its lights id (the hazard lights)
    "impostor_keyed": range(5, 41),  # …on the movement id, signing with the computer's key
    "secoc": (True,),  # the campaign runs with authenticated commands (drawn at its start)
    # the actuators and sensors
    "dac": ("fail", "alternate", "alternate", "restore"),
    "stall": ("short", "long"),  # a DAC write hangs for a quarter or 1.5 watchdog periods
    "dac_slow": (0.002, 0.08),  # every DAC transfer takes this long, and succeeds
    "line": ("turn_left_light", "brake_light", "hydrobrake"),  # an output dies: the loop ends
    "wheel_sensor": (False, True),
    "hydrobrake": (False, True),  # builds no pressure, or works again
    "ebrake": (False,),  # the spring brake fails to engage
    "servo": (False, True),  # stuck, or free again
    "encoder": (False,),  # the steering encoder gives no reading
}
"""Every action a step may name, with the values it may take (a range: any whole number in it)."""

OPERATOR = frozenset({"arm", "flick", "handover", "rc_throttle", "can_throttle"})
"""What an operator does: drawn more often than any fault, so the robot is mostly driving."""


@dataclass(frozen=True, slots=True)
class Step:
    """Wait `delay_s`, then do `action` with `value` (one of `VOCABULARY[action]`)."""

    delay_s: float
    action: str
    value: object = None


# --- compiling steps into scenario events ----------------------------------------------------


@dataclass(slots=True)
class _Compiler:
    """Turns steps into timed scenario events, following what they do to the switch and the
    remote stop request (a flick returns to where the switch was, a re-enable repeats the
    request, a handover goes to the other source)."""

    robot: RobotConfig
    events: list[Event] = field(default_factory=list)
    switch: ControlMode = STOP
    remote_stop: bool = False
    pending: list[tuple[float, int, Event]] = field(default_factory=list)
    _order: int = 0

    def compile(self, steps: Iterable[Step]) -> tuple[Event, ...]:
        self._emit(Event(0.0, "rc", {"gear": "forward"}))
        start = {"steering": 0.0, "throttle": 0.0, "brake": 0.0, "gear": "forward"}
        self._emit(Event(0.0, "hlc", start))
        at_s = 0.0
        for step in steps:
            at_s = round(at_s + step.delay_s, 6)
            self._flush(at_s)
            handler: Callable[[float, Any], None] = getattr(self, f"_{step.action}")
            handler(at_s, step.value)
        self._flush(float("inf"))
        return tuple(self.events)

    def _flush(self, until_s: float) -> None:
        while self.pending and self.pending[0][0] <= until_s:
            self._emit(heapq.heappop(self.pending)[2])

    def _emit(self, event: Event) -> None:
        if event.kind == "rc" and "mode" in event.values:
            self.switch = ControlMode[event.values["mode"].upper()]
        if event.kind == "hlc_control":
            self.remote_stop = event.values["remote_stop"]
        self.events.append(event)

    def _later(self, at_s: float, kind: str, values: dict[str, Any]) -> None:
        self._order += 1
        heapq.heappush(
            self.pending, (round(at_s, 6), self._order, Event(round(at_s, 6), kind, values))
        )

    def _fault(self, at_s: float, fault: str, **values: Any) -> None:
        self._emit(Event(at_s, "fault", {"fault": fault, "count": 1, **values}))

    # one method per action of VOCABULARY

    def _switch(self, at_s: float, mode: ControlMode) -> None:
        self._emit(Event(at_s, "rc", {"mode": mode.name.lower()}))

    def _arm(self, at_s: float, mode: ControlMode) -> None:
        self._switch(at_s, STOP)
        if mode is RC:
            self._later(at_s + ARM_HOLD_S, "rc", {"throttle": 0.0, "mode": "rc"})
        else:
            self._later(at_s + ARM_HOLD_S, "hlc", {"throttle": 0.0})
            self._later(at_s + ARM_HOLD_S, "rc", {"mode": "can"})

    def _flick(self, at_s: float, back_after_s: float) -> None:
        back = self.switch
        self._switch(at_s, STOP)
        if back is not STOP:
            self._later(at_s + back_after_s, "rc", {"mode": back.name.lower()})

    def _handover(self, at_s: float, throttle: float) -> None:
        if self.switch is not RC:
            self._emit(Event(at_s, "rc", {"throttle": throttle, "mode": "rc"}))
            return
        self._emit(Event(at_s, "hlc", {"throttle": throttle}))
        self._later(at_s + HANDOVER_LEAD_S, "rc", {"mode": "can"})

    def _rc_throttle(self, at_s: float, value: float) -> None:
        self._emit(Event(at_s, "rc", {"throttle": value}))

    def _can_throttle(self, at_s: float, value: float) -> None:
        self._emit(Event(at_s, "hlc", {"throttle": value}))

    def _rc_gear(self, at_s: float, gear: Gear) -> None:
        self._emit(Event(at_s, "rc", {"gear": gear.name.lower()}))

    def _rc_steer(self, at_s: float, value: float) -> None:
        self._emit(Event(at_s, "rc", {"steering": value}))

    def _rc_lights(self, at_s: float, on: bool) -> None:
        self._emit(Event(at_s, "rc", {"low_beam": on, "hazard": on}))

    def _can_gear(self, at_s: float, gear: Gear) -> None:
        self._emit(Event(at_s, "hlc", {"gear": gear.name.lower()}))

    def _can_steer(self, at_s: float, value: float) -> None:
        self._emit(Event(at_s, "hlc", {"steering": value}))

    def _can_brake(self, at_s: float, value: float) -> None:
        self._emit(Event(at_s, "hlc", {"brake": value}))

    def _can_lights(self, at_s: float, on: bool) -> None:
        self._emit(Event(at_s, "hlc_lights", {"turn_left": on, "low_beam": on}))

    def _chatter(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "switch_chatter", count=frames)

    def _rc_link(self, at_s: float, up: bool) -> None:
        self._fault(at_s, "rc_link_restored" if up else "rc_link_lost")

    def _rc_failsafe(self, at_s: float, on: bool) -> None:
        self._fault(at_s, "rc_failsafe" if on else "rc_failsafe_off")

    def _rc_implausible(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "rc_implausible", count=frames)

    def _rc_corrupt(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "ibus_corrupt", count=frames)

    def _rc_garbage(self, at_s: float, size: int) -> None:
        self._fault(at_s, "ibus_garbage", count=size)

    def _can_link(self, at_s: float, up: bool) -> None:
        self._fault(at_s, "can_resume" if up else "can_silence")

    def _can_repeat(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "can_corrupt_counter", count=frames)

    def _can_corrupt(self, at_s: float, how: str) -> None:
        self._fault(at_s, f"can_corrupt_{how}", count=3)

    def _can_cable(self, at_s: float, plugged: bool) -> None:
        self._fault(at_s, "can_plug" if plugged else "can_unplug")

    def _can_flood(self, at_s: float, load: float) -> None:
        if load:
            self._fault(at_s, "can_flood", load=load)
        else:
            self._fault(at_s, "can_flood_off")

    def _remote_stop(self, at_s: float, on: bool) -> None:
        self._emit(Event(at_s, "hlc_control", {"remote_stop": on, "re_enable": False}))

    def _re_enable(self, at_s: float, _value: None) -> None:
        self._emit(
            Event(at_s, "hlc_control", {"remote_stop": self.remote_stop, "re_enable": False})
        )
        self._later(
            at_s + RE_ENABLE_RISE_S,
            "hlc_control",
            {"remote_stop": self.remote_stop, "re_enable": True},
        )

    def _impostor(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "can_impostor", count=frames)

    def _impostor_control(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "can_impostor_control", count=frames)

    def _impostor_lights(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "can_impostor_lights", count=frames)

    def _impostor_keyed(self, at_s: float, frames: int) -> None:
        self._fault(at_s, "can_impostor", count=frames, keyed=True)

    def _secoc(self, _at_s: float, _on: bool) -> None:
        return  # the whole campaign is authenticated (`compile_steps`)

    def _dac_slow(self, at_s: float, transfer_s: float) -> None:
        self._fault(at_s, "dac_slow", stall_s=transfer_s)

    def _line(self, at_s: float, name: str) -> None:
        self._fault(at_s, "line_dead", line=name)

    def _dac(self, at_s: float, how: str) -> None:
        faults = {"fail": "dac_fail", "alternate": "dac_nak_alternate", "restore": "dac_restore"}
        self._fault(at_s, faults[how])

    def _stall(self, at_s: float, length: str) -> None:
        stall_s = round(STALL_OF_WATCHDOG[length] * self.robot.timeouts.watchdog_s, 6)
        self._fault(at_s, "dac_stall", stall_s=stall_s)

    def _wheel_sensor(self, at_s: float, alive: bool) -> None:
        self._fault(at_s, "wheel_sensor_restore" if alive else "wheel_sensor_dead")

    def _hydrobrake(self, at_s: float, works: bool) -> None:
        self._fault(at_s, "hydrobrake_restore" if works else "hydrobrake_fail")

    def _ebrake(self, at_s: float, _works: bool) -> None:
        self._fault(at_s, "ebrake_fail")

    def _servo(self, at_s: float, free: bool) -> None:
        self._fault(at_s, "servo_free" if free else "servo_stuck")

    def _encoder(self, at_s: float, _works: bool) -> None:
        self._fault(at_s, "encoder_fail")


def compile_steps(steps: Iterable[Step], robot: RobotConfig, name: str = "campaign") -> Scenario:
    """The scenario that does what `steps` do, ending `TAIL_S` after the last of them."""
    steps = list(steps)
    events = _Compiler(robot).compile(steps)
    end_s = max((event.at_s for event in events), default=0.0)
    end_s = max(end_s, sum(step.delay_s for step in steps))
    return Scenario(
        name=name,
        description=f"a fault campaign of {len(steps)} steps",
        duration_s=round(end_s + TAIL_S, 6),
        events=events,
        expectations=(),
        authenticated=any(step.action == "secoc" for step in steps),
    )


# --- telling the oracle what each event did --------------------------------------------------


@dataclass(slots=True)
class OracleWitness:
    """Tells the oracle what an event applied to the world means for the outputs: which faults
    began or ended, where the switch went, what each source asks for."""

    oracle: HazardOracle
    clock: VirtualClock
    authenticated: bool = False  # commands signed: a second sender without the key is harmless
    remote_stop: bool = False
    re_enable: bool = False

    def __call__(self, event: Event, now: float) -> None:
        getattr(self, f"_{event.kind}")(event.values, now)

    def _rc(self, values: dict[str, Any], now: float) -> None:
        oracle = self.oracle
        if "throttle" in values:
            oracle.set_throttle(RC, max(float(values["throttle"]), 0.0), now)
        if "mode" in values:
            mode = ControlMode[str(values["mode"]).upper()]
            oracle.set_switch(mode, now)
            if mode is CAN and oracle.faults & CAN_ONLY:
                oracle.stop_event("can_lost", now)

    def _hlc(self, values: dict[str, Any], now: float) -> None:
        if "throttle" in values:
            self.oracle.set_throttle(CAN, float(values["throttle"]), now)

    def _hlc_lights(self, _values: dict[str, Any], _now: float) -> None:
        return

    def _hlc_control(self, values: dict[str, Any], now: float) -> None:
        remote_stop, re_enable = bool(values["remote_stop"]), bool(values["re_enable"])
        if remote_stop != self.remote_stop:
            self.remote_stop = remote_stop
            if not remote_stop or not self.oracle.faults & CAN_SILENT:
                self.oracle.fault("remote_stop", remote_stop, now)  # arriving: every mode
        if re_enable and not self.re_enable:
            self.oracle.re_enable(now)
        self.re_enable = re_enable

    def _can_fault(self, kind: str, active: bool, now: float) -> None:
        oracle = self.oracle
        if oracle.switch is CAN or not active:
            oracle.fault(kind, active, now)
        else:
            oracle.faults.add(kind)  # blocks arming into CAN; RC drives on
            oracle.fault_changed_at = now

    def _can_back(self, kind: str, now: float) -> None:
        self._can_fault(kind, False, now)
        if self.remote_stop and not self.oracle.faults & CAN_SILENT:
            self.oracle.fault("remote_stop", True, now)  # a request made while silent arrives

    def _fault(self, values: dict[str, Any], now: float) -> None:
        oracle, fault, count = self.oracle, str(values["fault"]), int(values.get("count", 1))
        frame_s = oracle.timing.frame_s
        actions: dict[str, Callable[[], None]] = {
            "switch_chatter": lambda: oracle.chatter(count, now),
            "rc_link_lost": lambda: oracle.fault("rc_link_lost", True, now),
            "rc_link_restored": lambda: oracle.fault("rc_link_lost", False, now),
            "rc_failsafe": lambda: oracle.fault("rc_failsafe", True, now),
            "rc_failsafe_off": lambda: oracle.fault("rc_failsafe", False, now),
            "rc_implausible": lambda: oracle.implausible(count, now),
            "ibus_corrupt": lambda: oracle.blind(RC, now, now + (count + 1) * frame_s),
            "ibus_garbage": lambda: oracle.blind(RC, now, now + (count // 32 + 2) * frame_s),
            "can_silence": lambda: self._can_fault("can_lost", True, now),
            "can_resume": lambda: self._can_back("can_lost", now),
            "can_unplug": lambda: self._can_fault("can_unplugged", True, now),
            "can_plug": lambda: self._can_back("can_unplugged", now),
            "can_impostor": lambda: self._impostor(count, now, values),
            "can_impostor_control": lambda: self._impostor(count, now, values),
            "dac_slow": lambda: self._slow_dac(float(values["stall_s"]), now),
            "line_dead": lambda: oracle.line_died(str(values["line"])),
            "ebrake_fail": lambda: setattr(oracle, "ebrake_failed", True),
            "dac_fail": lambda: oracle.dac_failing(now, every_other=False),
            "dac_nak_alternate": lambda: oracle.dac_failing(now, every_other=True),
            "dac_restore": lambda: self._dac_restored(now),
            "dac_stall": lambda: self._stall(float(values["stall_s"]), now),
            "wheel_sensor_dead": oracle.sensor_dies,
            "wheel_sensor_restore": oracle.sensor_restored,
            "hydrobrake_fail": lambda: setattr(oracle, "brake_failed", True),
            "hydrobrake_restore": lambda: setattr(oracle, "brake_failed", False),
        }
        if fault.startswith("can_corrupt_"):
            oracle.blind(CAN, now, now + (count + 1) * IMPOSTOR_PERIOD_S)
        elif fault in actions:
            actions[fault]()
        # Anything else (a flood, the steering failing, an encoder dead, a second sender on the
        # lights' id) may stop the robot or not: the oracle never needs to know that it did.

    def _dac_restored(self, now: float) -> None:
        self.oracle.fault("dac_fail", False, now)
        self.oracle.fault("dac_slow", False, now)
        self.oracle.write_lag_s = 0.0

    def _slow_dac(self, transfer_s: float, now: float) -> None:
        """Every DAC transfer crawls: each pass that writes the DAC is that much longer, and one
        slower than any robot file's budget is a fault (category 0)."""
        self.oracle.write_lag_s = 2 * transfer_s  # two transfers a pass, at most
        if transfer_s > SLOW_TRANSFER_S:
            self.oracle.hang(now, now + self.oracle.timing.driving_period_s + transfer_s)
            self.oracle.fault("dac_slow", True, now)
        else:  # ordinary transfers again: a crawl before is over (its latch is the switch's)
            self.oracle.fault("dac_slow", False, now)

    def _impostor(self, frames: int, now: float, values: dict[str, Any]) -> None:
        if self.authenticated and not values.get("keyed"):
            return  # its frames never verify, and cost the computer's no trust: no effect
        self._can_fault("can_impostor", True, now)
        # Over when its last frame is sent: the controller may trust the id again soon after
        # (a window of good frames), and the oracle must never think a fault lasts longer.
        end_s = now + frames * IMPOSTOR_PERIOD_S
        self.clock.call_at(end_s, lambda: self._can_fault("can_impostor", False, end_s))

    def _stall(self, stall_s: float, now: float) -> None:
        timing = self.oracle.timing
        if stall_s > timing.watchdog_s:
            # The next DAC write (within one control period) hangs; the watchdog's poll trips.
            trips_s = now + timing.control_period_s + timing.watchdog_s + 2 * WATCHDOG_POLL_S
            self.oracle.stall(now, trips_s)
        else:  # the next DAC write (within one control period) hangs, short of a trip
            self.oracle.hang(now, now + timing.control_period_s + stall_s)


# --- running a campaign ------------------------------------------------------------------------


@dataclass(slots=True)
class CampaignResult:
    """What one campaign did and what the oracle found."""

    oracle: HazardOracle
    simulated_s: float
    events: int
    transitions: set[str]
    scenario: Scenario


class Campaign:
    """One robot (the simulator's, or the one a robot file describes), one sequence of steps,
    one oracle."""

    def __init__(self, robot: RobotConfig | None = None) -> None:
        self.robot = robot or default_sim_config()

    def run(self, steps: Iterable[Step]) -> CampaignResult:
        """Play the steps, then `TAIL_S` more; the oracle has seen every pass."""
        return self.run_scenario(compile_steps(steps, self.robot))

    def run_scenario(
        self, scenario: Scenario, prepare: Callable[[SimRun], None] | None = None
    ) -> CampaignResult:
        """Play a compiled campaign (or any scenario) with the oracle watching; `prepare` is
        called with the run before it starts (a test attaching its own recorders)."""
        run = SimRun(self.robot, scenario)
        if prepare is not None:
            prepare(run)
        clock = cast(VirtualClock, run.world.clock)
        timing = OracleTiming.for_robot(self.robot)
        dac = self.robot.drive.dac
        oracle = HazardOracle(run.world, dac.throttle_channel, dac.regen_channel, timing=timing)
        run.on_event.append(OracleWitness(oracle, clock, scenario.authenticated))
        run.on_exit.append(oracle.exited)
        log = TransitionLog(run)
        run.runtime.on_cycle.append(oracle.observe)
        run.runtime.on_cycle.append(log.observe)
        with _quiet_runtime():  # a campaign's failing DAC at its end is no news: the oracle judges
            run.run()
        return CampaignResult(oracle, run.duration_s, len(scenario.events), log.seen, scenario)


@contextlib.contextmanager
def _quiet_runtime() -> Iterator[None]:
    """The runtime's log (safe writes that failed at its exit) silenced for one campaign."""
    logger = logging.getLogger("bywire.runtime.app")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


@dataclass(slots=True)
class TransitionLog:
    """The rows of the supervisor's transition table a running controller took."""

    run: SimRun
    seen: set[str] = field(default_factory=set)
    previous: SupervisorState = field(default_factory=SupervisorState)

    def observe(self, _now: float) -> None:
        state = self.run.runtime.state.supervisor
        if state != self.previous:  # a new but equal state every pass: no row was taken
            self.seen.update(transition_labels(self.previous, state))
            self.previous = state
