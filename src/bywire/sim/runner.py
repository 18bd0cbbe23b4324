"""One simulated run: the real controller on the simulated robot, driven by a scenario.

The scenario's events are timers on the world's clock; the controller is the same `Runtime` that
drives the real robot. After every pass of the controller's loop the robot is observed: that is
where expectations are checked (to the instant the outputs changed) and the record is sampled.
"""

from __future__ import annotations

import functools
import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from bywire.config import RobotConfig
from bywire.config.security_setup import controller_receiver, sender_signer, simulated_run_key
from bywire.control.supervisor import Cause
from bywire.errors import ConfigError, HardwareError
from bywire.hal.hardware import Hardware
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.simulated.clock import RealtimeClock, ScaledRealtimeClock, VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.world import SimWorld
from bywire.model import LIGHTS_OFF, ControlMode, Gear
from bywire.ros2.settings import settings_from
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import POLL_S as WATCHDOG_POLL_S
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.sim.bridge_computer import SimBridge
from bywire.sim.conditions import conditions_hold
from bywire.sim.faults import BY_NAME, SilencedComputer
from bywire.sim.observe import Observation, observe
from bywire.sim.scenario import Event, Expectation, Scenario
from bywire.sim.trace import Trace

RECORD_PERIOD_S = 0.010  # the plot's resolution; expectations see every pass of the loop
SAFE_SEARCH_S = 2.0  # how long after a fault the run looks for safe outputs


@dataclass(slots=True)
class Verdict:
    """How one expectation fared; `measured_s` is the time from its event to when it held."""

    expectation: Expectation
    passed: bool | None = None  # None while undecided
    measured_s: float | None = None
    window: tuple[float, float] | None = None


@dataclass(slots=True)
class FaultTiming:
    """A labelled event and when the outputs were next safe after it.

    The search ends at the next labelled event, so a later STOP is never credited to an earlier,
    unrelated event. `already_safe`: the outputs were safe when it happened.
    """

    event: Event
    at_s: float
    already_safe: bool
    safe_at_s: float | None = None
    searching: bool = True

    @property
    def label(self) -> str:
        return self.event.label or ""

    @property
    def time_to_safe_s(self) -> float | None:
        return None if self.safe_at_s is None else self.safe_at_s - self.at_s


@dataclass(slots=True)
class RunRecord:
    """Everything a run leaves for the summary, the plot and the checks."""

    samples: Trace[Observation] = field(default_factory=Trace)
    """What the plot draws: one observation every RECORD_PERIOD_S, thinned on a long run."""
    verdicts: list[Verdict] = field(default_factory=list)
    fault_timings: list[FaultTiming] = field(default_factory=list)
    top_speed_mps: float = 0.0
    ended_by: str | None = None  # the output failure that ended the controller, if one did
    error_flags_seen: int = 0  # once the robot had been armed (or had left power-up)
    power_up_flags: int = 0  # while still in the power-up state, before the first arming


def run_clock(
    scenario: Scenario, *, realtime: bool = False, speed: float | None = None
) -> VirtualClock:
    """A run's clock: virtual (as fast as it goes) unless `realtime`, the scenario or `speed`
    asks for the wall clock; at `speed` N (SITL's `--speed`) N simulated seconds a wall second.
    ConfigError for a speed a real-time scenario (one that stalls the loop in real time)
    cannot keep."""
    scaled = speed is not None and speed != 1.0
    if scaled and scenario.realtime:
        raise ConfigError(
            f"--speed {speed:g}: scenario {scenario.name!r} stalls the loop in real time,"
            " which a faster clock cannot (drop --speed)"
        )
    if scaled:
        return ScaledRealtimeClock(speed=speed or 1.0)
    return RealtimeClock() if realtime or scenario.realtime or speed is not None else VirtualClock()


class SimRun:
    """Build the world and the controller for one scenario; `run()` plays it to the end."""

    def __init__(
        self,
        robot: RobotConfig,
        scenario: Scenario,
        *,
        realtime: bool = False,
        duration_s: float | None = None,
        clock: VirtualClock | None = None,
        speed: float | None = None,
    ) -> None:
        """`clock`: one made beforehand with `run_clock` (real time when the run is), so that
        what must be running before the controller's first pass (the telemetry writer) can start
        on it first; by default `run_clock(scenario, realtime=..., speed=...)`. `speed`: paced by
        the wall clock at that many times real time (`--speed N`)."""
        self.robot = robot
        self.scenario = scenario
        self.duration_s = scenario.duration_s if duration_s is None else duration_s
        if clock is None:
            clock = run_clock(scenario, realtime=realtime, speed=speed)
        elif (realtime or scenario.realtime) and not isinstance(clock, RealtimeClock):
            raise ValueError(f"{scenario.name} runs on real time; the clock given is virtual")
        realtime = isinstance(clock, RealtimeClock)
        scaled = isinstance(clock, ScaledRealtimeClock) and clock.speed != 1.0
        self.world: SimWorld = SimWorld.from_robot(clock, robot)
        # The watchdog's own thread measures the wall clock: only where the run is paced 1:1 by
        # it; elsewhere a timer checks it on the run's clock.
        self._realtime = realtime and not scaled
        self._signer: SecocSigner | None = None
        self.secoc = self._authentication(robot, scenario)
        self.bridge: SimBridge | None = None
        """The ROS 2 bridge's CAN side, when the scenario's computer is the bridge."""
        if scenario.computer == "bridge":
            settings = settings_from(dict(scenario.bridge))
            self.bridge = SimBridge.build(self.world, robot, settings, self._signer)
        self.runtime = self._controller(self.world.hardware)
        if self.runtime.watchdog is not None and not self._realtime:
            # On virtual time the watchdog runs on the simulated clock, checked by a timer where
            # the thread would poll: a write stalled in simulated time trips it exactly, and the
            # wall clock's speed never does. The timer checks the controller of the moment
            # (`put_controller_on` may build another before the run).
            PeriodicTimer(clock, WATCHDOG_POLL_S, self._check_watchdog).start()
        self.record = RunRecord(verdicts=[Verdict(e) for e in scenario.expectations])
        self.started_at = clock.now()
        self.random = random.Random(robot.sim.seed)
        """The run's own randomness (garbage bytes): seeded by the configuration."""
        self._movement: dict[str, Any] = {
            "steering": 0.0,
            "throttle": 0.0,
            "brake": 1.0,
            "gear": "neutral",
        }
        self._next_record_s = self.started_at
        self.runtime.on_cycle.append(self._observe)
        self.on_event: list[Callable[[Event, float], None]] = []
        """Called with each event just applied and the time (the hazard oracle's witness)."""
        self.on_exit: list[Callable[[float], None]] = []
        """Called with the time when the controller ended on a failed output (a dead line),
        after its exit path wrote the safe state: what it left is observed once more."""

    def _controller(self, hardware: Hardware) -> Runtime:
        """The controller on `hardware`: the watchdog's own thread only on real time."""
        return Runtime(
            hardware,
            RuntimeConfig.from_robot(self.robot),
            watchdog_thread=self._realtime,
            secoc=self.secoc,
        )

    def _check_watchdog(self, _tick_s: float) -> None:
        watchdog = self.runtime.watchdog
        if watchdog is not None:
            watchdog.check()

    def put_controller_on(self, wrap: Callable[[Hardware], Hardware]) -> Runtime:
        """Before the run: rebuild the controller on `wrap(world.hardware)` (taped ports, for a
        run record), built exactly as the first one (the same watchdog, on the same clock, and
        the same verifier) and observed by the same observers. Whoever took `runtime` before
        this call holds a controller that never runs."""
        before = self.runtime
        self.runtime = self._controller(wrap(self.world.hardware))
        self.runtime.on_cycle.extend(before.on_cycle)
        return self.runtime

    def _authentication(self, robot: RobotConfig, scenario: Scenario) -> SecocReceiver | None:
        """With [security] on or an authenticated scenario: the computer signs, the controller
        verifies, both with the run's key (`simulated_run_key`) and freshness in memory (the
        restarts that persisted freshness is for are tested in tests/security)."""
        if not (robot.security.enabled or scenario.authenticated):
            return None
        key = simulated_run_key(robot.security, robot.sim.seed)
        self._signer = sender_signer(key)  # the bridge's link signs with it, or the computer
        if scenario.computer != "bridge":
            self.world.hlc.sign_with(self._signer)
        for impostor in self.world.impostors.values():
            impostor.forge_authenticator = True
        memory = replace(robot.security, freshness_file=None)
        return controller_receiver(memory, key)

    @property
    def computer(self) -> SilencedComputer:
        """The higher-level computer sending the commands: the bridge, or `world.hlc`."""
        return self.bridge if self.bridge is not None else self.world.hlc

    def add_can_monitor(self, monitor: Callable[[LoggedFrame], None]) -> None:
        """Called with every frame that crosses the bus (the CAN log writer)."""
        self.world.bus.add_monitor(monitor)

    def every(self, period_s: float, callback: Callable[[float], None]) -> None:
        """Call `callback(elapsed_s)` every `period_s` of simulated time (progress display)."""

        def tick() -> None:
            callback(self.world.clock.now() - self.started_at)
            self.world.clock.call_at(self.world.clock.now() + period_s, tick)

        self.world.clock.call_at(self.started_at + period_s, tick)

    def run(self) -> RunRecord:
        """Play the scenario to its end and decide every expectation."""
        clock = self.world.clock
        for event in self.scenario.events:
            clock.call_at(self.started_at + event.at_s, functools.partial(self._apply, event))
        self.world.start(hlc=self.bridge is None)
        if self.bridge is not None:
            self.bridge.start()
        try:
            self.runtime.run(until_s=self.started_at + self.duration_s)
        except HardwareError as error:  # as on the robot: the loop ends, its exit path is safe
            now = clock.now()
            self.record.ended_by = (
                f"the controller stopped at {now - self.started_at:.3f} s: {error}"
            )
            self._observe(now)
            for listener in self.on_exit:
                listener(now)
        self.world.stop()
        if self.bridge is not None:
            self.bridge.silence()
        for verdict in self.record.verdicts:
            if verdict.passed is None:
                verdict.passed = False
        return self.record

    # --- events -------------------------------------------------------------------------------

    def _apply(self, event: Event) -> None:
        now = self.world.clock.now()
        if event.label:
            for timing in self.record.fault_timings:
                timing.searching = False
            observation = self._observation()
            already_safe = observation is None or observation.safe
            self.record.fault_timings.append(FaultTiming(event, now, already_safe))
            for verdict in self.record.verdicts:
                expectation = verdict.expectation
                if expectation.after == event.label and verdict.window is None:
                    length_s = expectation.during_s or expectation.within_s or 0.0
                    verdict.window = (now, now + length_s)
        appliers: dict[str, Callable[[dict[str, Any]], None]] = {
            "rc": self._apply_rc,
            "hlc": self._apply_hlc,
            "hlc_lights": self._apply_hlc_lights,
            "hlc_control": self._apply_hlc_control,
            "fault": self._apply_fault,
            "estop": self._apply_estop,
            "planner": self._apply_planner,
            "bridge_service": self._apply_bridge_service,
            "world": self._apply_world,
        }
        appliers[event.kind](event.values)
        for listener in self.on_event:
            listener(event, now)

    def _apply_rc(self, values: dict[str, Any]) -> None:
        rc = self.world.rc
        if "mode" in values:
            rc.set_mode(ControlMode[str(values["mode"]).upper()])
        if "gear" in values:
            rc.set_gear(Gear[str(values["gear"]).upper()])
        if "steering" in values:
            rc.set_steering(float(values["steering"]))
        if "throttle" in values:
            rc.set_pedal(float(values["throttle"]))
        if "low_beam" in values:
            rc.set_low_beam(bool(values["low_beam"]))
        if "hazard" in values:
            rc.set_hazard(bool(values["hazard"]))
        if "mode_raw" in values:
            rc.set_mode_raw(int(values["mode_raw"]))

    def _apply_hlc(self, values: dict[str, Any]) -> None:
        self._movement.update(values)
        movement = self._movement
        self.world.hlc.set_movement(
            float(movement["steering"]),
            float(movement["throttle"]),
            float(movement["brake"]),
            Gear[str(movement["gear"]).upper()],
        )

    def _apply_hlc_lights(self, values: dict[str, Any]) -> None:
        requests = {key: bool(value) for key, value in values.items()}
        self.world.hlc.set_lights(replace(LIGHTS_OFF, **requests))

    def _apply_hlc_control(self, values: dict[str, Any]) -> None:
        self.world.hlc.set_control(
            bool(values.get("remote_stop", False)), bool(values.get("re_enable", False))
        )

    def _apply_estop(self, values: dict[str, Any]) -> None:
        if values.get("pressed"):
            self.world.estop.press()
        elif "pressed" in values:
            self.world.estop.release()

    def _running_bridge(self) -> SimBridge:
        if self.bridge is None:
            raise ValueError(f'{self.scenario.name}: planner events need computer = "bridge"')
        return self.bridge

    def _apply_planner(self, values: dict[str, Any]) -> None:
        self._running_bridge().plan(values)

    def _apply_bridge_service(self, values: dict[str, Any]) -> None:
        bridge = self._running_bridge()
        if values.get("enable"):
            bridge.enable()
        if "remote_stop" in values:
            bridge.remote_stop(bool(values["remote_stop"]))

    def _apply_world(self, values: dict[str, Any]) -> None:
        if "grade" in values:
            self.world.vehicle.grade = float(values["grade"])

    def _apply_fault(self, values: dict[str, Any]) -> None:
        BY_NAME[str(values["fault"])].apply(self, values)

    def stall_loop(self, stall_s: float) -> None:
        """Hang the controller's thread (this timer runs in it), watching the outputs meanwhile:
        only the watchdog's own thread can make them safe now."""
        end_s = time.perf_counter() + stall_s
        while time.perf_counter() < end_s:
            time.sleep(0.002)
            self._observe(self.world.clock.now())

    def failsafe_values(self) -> dict[int, int]:
        """A FlySky receiver's output on loss: the transmitter's failsafe values. Sticks centred,
        switches as they were, and the configured signature channel at 900 µs."""
        mapping = self.robot.rc.mapping
        return {
            mapping.steering.channel: mapping.steering.center_raw,
            mapping.throttle_brake.channel: mapping.throttle_brake.center_raw,
            mapping.failsafe.channel: mapping.failsafe.below_raw - 50,
        }

    # --- observation --------------------------------------------------------------------------

    def _observation(self) -> Observation | None:
        outputs = self.runtime.outputs
        if outputs is None:
            return None
        observation = observe(self.world, outputs)
        if self.bridge is None:
            return observation
        return replace(
            observation,
            bridge_unshown_drop=self.bridge.unshown_drop,
            bridge_throttle_norm=self.bridge.throttle_norm,
        )

    def _observe(self, now: float) -> None:
        """After each pass of the loop: flags always; a full observation when one is due."""
        outputs = self.runtime.outputs
        if outputs is None:
            return
        if Cause.POWER_UP in outputs.causes:
            self.record.power_up_flags |= outputs.error_flags
        else:
            self.record.error_flags_seen |= outputs.error_flags
        recording = now >= self._next_record_s
        if not (recording or self._watching(now)):
            return
        observation = self._observation()
        if observation is None:
            return
        if recording:
            self.record.samples.append(observation)
            self.record.top_speed_mps = max(self.record.top_speed_mps, abs(observation.speed_mps))
            self._next_record_s = now + RECORD_PERIOD_S
        self._judge(observation)

    def _watching(self, now: float) -> bool:
        """True while a deadline runs or a timed expectation is due: observe every pass."""
        timings = (t.searching and not t.already_safe for t in self.record.fault_timings)
        return any(timings) or any(self._due(verdict, now) for verdict in self.record.verdicts)

    def _due(self, verdict: Verdict, now: float) -> bool:
        at_s = verdict.expectation.at_s
        if at_s is not None:
            return verdict.passed is None and now >= self.started_at + at_s
        return verdict.window is not None and (verdict.passed is None or verdict.measured_s is None)

    def _judge(self, observation: Observation) -> None:
        now = observation.time_s
        for timing in self.record.fault_timings:
            if not timing.searching or timing.already_safe:
                continue
            if observation.safe and now - timing.at_s <= SAFE_SEARCH_S:
                timing.safe_at_s, timing.searching = now, False
        for verdict in self.record.verdicts:
            if verdict.passed is None or verdict.measured_s is None:
                self._judge_one(verdict, observation)

    def _judge_one(self, verdict: Verdict, observation: Observation) -> None:
        """Decide a pending expectation; a missed deadline still gets its measured time."""
        now, expectation = observation.time_s, verdict.expectation
        if expectation.at_s is not None:
            if verdict.passed is None and now >= self.started_at + expectation.at_s:
                verdict.passed = conditions_hold(observation, expectation.conditions)
            return
        if verdict.window is None:
            return
        start_s, end_s = verdict.window
        if expectation.during_s is not None:
            if not conditions_hold(observation, expectation.conditions) and now <= end_s:
                verdict.passed, verdict.measured_s = False, now - start_s  # when it broke
            elif now > end_s and verdict.passed is None:
                verdict.passed, verdict.measured_s = True, expectation.during_s
            return
        if conditions_hold(observation, expectation.conditions):
            if verdict.passed is None:
                verdict.passed = now <= end_s
            if now - start_s <= SAFE_SEARCH_S:
                verdict.measured_s = now - start_s
        elif now > end_s and verdict.passed is None:
            verdict.passed = False
