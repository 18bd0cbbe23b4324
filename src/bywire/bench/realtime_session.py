"""The real-time session: the controller on the simulated robot, a nominal and a flood phase.

Timeline, in seconds after the controller starts (D = one phase)::

    0        RC transmitter in STOP with gear forward; the computer asks for zero throttle
    0.5      mode switch to CAN: the robot arms (moved through STOP with throttle at zero)
    1        nominal phase: CAN sweep; half-way, mode switch to RC and RC sweep
    1 + D    flood phase: other nodes fill the bus; CAN sweep, then RC sweep as before
    1 + 2D   stop (with `look`: a "feed" phase, the telemetry feed on and a Foxglove client
             attached, then a "dashboard" phase, the dashboard's child process attached; nominal
             load, each as the nominal phase; see `bywire.bench.looking`)

A session made `authenticated` has one phase instead, "secoc_flood": the flood phase with every
command signed by the computer and verified by the controller (SecOC), on a world and a
controller of its own (`bywire bench` runs it after the first session).

The clock is injected: the benchmark runs on a real-time clock, the tests on a virtual one (where
every latency is exactly zero); both are metered, to tell the simulator's CPU time apart. The
benchmark's own work is put a few ms after the 10 ms grid of the controller's deadlines, where
the loop is idle, so that it disturbs the figures least.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace

from bywire.bench.clocks import MeteredClock
from bywire.bench.latency import (
    DacWrite,
    SentCommand,
    ThrottleOutput,
    can_command,
    rc_command,
)
from bywire.bench.looking import LOOKING_PHASES, Onlookers
from bywire.bench.machine import peak_rss_bytes
from bywire.bench.phases import (
    Marks,
    PhaseResult,
    PhaseWindow,
    TaskFigures,
    latency_in,
    latency_intervals,
    pairing_in,
    stops_in,
)
from bywire.bench.sweeps import CanSweep, MovementLog, RcSweep
from bywire.bench.tail import PhaseTail, ProbedClock, explain_tail, gc_figures
from bywire.config import RobotConfig
from bywire.config.security_setup import controller_receiver, sender_signer, simulated_run_key
from bywire.control.governor import GovernorConfig
from bywire.hal.simulated.hlc import COMMAND_PERIOD_S
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.protocol import ibus
from bywire.runtime.loop import Runtime
from bywire.runtime.schedule import TaskStats
from bywire.runtime.settings import RuntimeConfig
from bywire.security.session import SecocReceiver

ARM_AT_S = 0.5
HANDOVER_S = 0.06  # the switch counts after 3 IBUS frames (23 ms); well inside the settle time
STOP_HOLD_S = 0.05  # a phase's arming: the switch held at STOP for 3 frames and a margin
FIRST_PHASE_AT_S = 1.0
GRID_OFFSET_S = 0.004
PROGRESS_PERIOD_S = 1.0
AUTHENTICATED_PHASE = "secoc_flood"
TAIL_THRESHOLD_S = 0.0005
"""A latency or a wake-up later than this is the tail `bywire bench --probe` explains."""

Progress = Callable[[str, float, float], None]
"""Called with the phase's name, seconds done and seconds in all (about once a second)."""


def bench_runtime_config(robot: RobotConfig) -> RuntimeConfig:
    """The robot's runtime configuration without the throttle slew limit and the speed governor.

    The sweeps raise the throttle in every frame; the interlocks' slew limit delays each rise on
    purpose, by up to a frame. Latency is the controller's reaction time, so it is measured with
    that limit lifted (falling throttle, brake and STOP are never slew-limited anyway). The
    sweeps also carry the simulated robot into the speed limit's band, where the governor holds
    the throttle below the command on purpose (`control.governor`): lifted too.
    """
    config = RuntimeConfig.from_robot(robot)
    interlocks = replace(config.control.interlocks, throttle_slew_up_per_s=1e6)
    control = replace(config.control, interlocks=interlocks, governor=GovernorConfig())
    return replace(config, control=control)


@dataclass(frozen=True, slots=True)
class BenchSettings:
    """How long each phase lasts, how full the flood makes the bus, how long a switch settles."""

    phase_s: float = 60.0
    flood_load: float = 1.0
    settle_s: float = 0.2
    look: bool = False  # the looking phases too: the cost of the feed and of the dashboard


@dataclass(frozen=True, slots=True)
class RealtimeResult:
    """Both phases' results and the process's peak resident memory at the end; on a
    `ProbedClock`, where each phase's tail came from."""

    phases: tuple[PhaseResult, ...]
    peak_rss_bytes: int
    tail: tuple[PhaseTail, ...] | None = None

    def then(self, later: RealtimeResult) -> RealtimeResult:
        """This session's phases, then a later session's (the authenticated one).

        The peak memory stays this session's: the later one builds a second world and
        controller in the same process, beside what the first left resident (`lock_memory`,
        a frozen collector), so the process' peak after it is no controller's footprint
        (75.8 MB against 57.9 MB, 2026-11-26)."""
        tail = None if self.tail is None or later.tail is None else self.tail + later.tail
        return RealtimeResult(self.phases + later.phases, self.peak_rss_bytes, tail)


class RealtimeSession:
    """One world, one controller, the sweeps and the phase timers on ``clock``."""

    def __init__(
        self,
        robot: RobotConfig,
        settings: BenchSettings,
        clock: MeteredClock,
        progress: Progress | None = None,
        *,
        authenticated: bool = False,
    ) -> None:
        """`authenticated`: one phase instead, "secoc_flood", with the bus flooded as in the
        flood phase and every command signed by the computer and verified by the controller
        (SecOC, as `bywire sim --authenticated`): what authentication costs in latency."""
        self.robot = robot
        self.clock = clock
        self.settings = settings
        self.progress = progress
        self.world = SimWorld.from_robot(clock, robot)
        secoc = _authenticate(self.world, robot) if authenticated else None
        self.runtime = Runtime(self.world.hardware, bench_runtime_config(robot), secoc=secoc)
        self.movement_log = MovementLog(self.world.bus)
        self.can_sweep = CanSweep(self.world)
        self.rc_sweep = RcSweep(self.world)
        self.writes: list[DacWrite] = []
        first_s = self.runtime.started_at + FIRST_PHASE_AT_S + GRID_OFFSET_S
        phase_s = settings.phase_s
        self.windows: tuple[PhaseWindow, ...] = (
            PhaseWindow("nominal", first_s, first_s + phase_s, None, settings.settle_s),
            PhaseWindow(
                "flood",
                first_s + phase_s,
                first_s + 2 * phase_s,
                settings.flood_load,
                settings.settle_s,
            ),
        )
        if authenticated:
            self.windows = (
                PhaseWindow(
                    AUTHENTICATED_PHASE,
                    first_s,
                    first_s + phase_s,
                    settings.flood_load,
                    settings.settle_s,
                ),
            )
        self.onlookers: Onlookers | None = None
        if settings.look and not authenticated:
            self.onlookers = Onlookers(self.runtime, self.world)
            self.windows += tuple(
                PhaseWindow(
                    name,
                    first_s + k * phase_s,
                    first_s + (k + 1) * phase_s,
                    None,
                    settings.settle_s,
                )
                for k, name in enumerate(LOOKING_PHASES, start=2)
            )

    def run(self) -> RealtimeResult:
        """Play the timeline to its end; the controller's outputs end safe."""
        self._schedule()
        try:
            self.runtime.run(until_s=self.windows[-1].end_s + 1.0)
        finally:
            if self.onlookers is not None:
                self.onlookers.close()
        self.world.stop()
        rss_bytes = peak_rss_bytes()
        commands = self.commands()
        phases = tuple(self._result(window, *commands) for window in self.windows)
        tail = None
        if isinstance(self.clock, ProbedClock):
            tail = tuple(self._tail(self.clock, window, *commands) for window in self.windows)
        return RealtimeResult(phases, rss_bytes, tail)

    # --- the timeline -------------------------------------------------------------------------

    def _schedule(self) -> None:
        world, clock = self.world, self.world.clock
        world.rc.set_gear(Gear.FORWARD)
        world.hlc.set_movement(0.0, 0.0, 0.0, Gear.FORWARD)
        first_s = self.runtime.started_at + GRID_OFFSET_S
        world.rc.start(first_s)
        world.hlc.start(first_s)
        world.vehicle.start(first_s)
        self.can_sweep.start(first_s + COMMAND_PERIOD_S / 2)
        self.rc_sweep.start(first_s + ibus.FRAME_PERIOD_S / 2)
        clock.call_at(self.runtime.started_at + ARM_AT_S, self._to_can)
        for window in self.windows:
            clock.call_at(window.start_s, functools.partial(self._begin, window))
            clock.call_at(window.half_s, self._to_rc)
            clock.call_at(window.end_s, functools.partial(self._end, window))
        clock.call_at(self.windows[-1].end_s, self.runtime.request_stop)
        if self.progress is not None:
            clock.call_at(self.windows[0].start_s + PROGRESS_PERIOD_S, self._report_progress)

    def _to_can(self) -> None:
        """Hand over to CAN as an operator would: both sources at zero throttle, the switch
        moved, and the computer's sweep only once the switch has counted (bumpless transfer)."""
        self._hand_over(ControlMode.CAN)
        self.world.clock.call_at(self.world.clock.now() + HANDOVER_S, self.can_sweep.activate)

    def _arm_can(self) -> None:
        """Arm into CAN as an operator does: both sources at zero, the switch held at STOP, then
        moved to CAN. Every phase starts so, whatever the last one ended in: a phase that fell
        to STOP (a stall the host caused) must not leave the next one measuring a robot at rest."""
        self.can_sweep.active = self.rc_sweep.active = False
        self.world.rc.set_throttle(0.0)
        self.world.hlc.set_movement(0.0, 0.0, 0.0, Gear.FORWARD)
        self.world.rc.set_mode(ControlMode.STOP)
        self.world.clock.call_at(self.world.clock.now() + STOP_HOLD_S, self._to_can)

    def _to_rc(self) -> None:
        self._hand_over(ControlMode.RC)
        self.world.clock.call_at(self.world.clock.now() + HANDOVER_S, self.rc_sweep.activate)

    def _hand_over(self, mode: ControlMode) -> None:
        self.can_sweep.active = self.rc_sweep.active = False
        self.world.rc.set_throttle(0.0)
        self.world.hlc.set_movement(0.0, 0.0, 0.0, Gear.FORWARD)
        self.world.rc.set_mode(mode)

    def _begin(self, window: PhaseWindow) -> None:
        for task in self.runtime.tasks:
            task.stats = TaskStats()
        if window.flood_load is not None:
            self.world.bus.flood(window.flood_load)
        self._arm_can()
        if self.onlookers is not None and window.name in LOOKING_PHASES:
            self.onlookers.start(window.name)
        window.started = Marks.take(self.clock, self.world.bus)
        if self.progress is not None:
            first, last = self.windows[0], self.windows[-1]
            self.progress(window.name, window.start_s - first.start_s, last.end_s - first.start_s)

    def _end(self, window: PhaseWindow) -> None:
        window.ended = Marks.take(self.clock, self.world.bus)
        window.task_stats = [(task, task.stats) for task in self.runtime.tasks]
        for task in self.runtime.tasks:
            task.stats = TaskStats()  # the phase's figures stay as they are now
        self.can_sweep.active = self.rc_sweep.active = False
        self.world.bus.stop_flood()
        if self.onlookers is not None and window.name in LOOKING_PHASES:
            self.onlookers.stop(window.name)
        self._collect_writes()

    def _collect_writes(self) -> None:
        """Copy the throttle channel's new history entries (the DAC trims old ones on long runs)."""
        channel = self.robot.drive.dac.throttle_channel
        after_s = self.writes[-1].time_s if self.writes else float("-inf")
        self.writes += [
            DacWrite(time_s, volts)
            for time_s, entry_channel, volts in self.world.dac.history
            if entry_channel == channel and time_s > after_s
        ]

    def _report_progress(self) -> None:
        if self.progress is None:
            return
        now = self.world.clock.now()
        first, last = self.windows[0], self.windows[-1]
        current = next((w for w in self.windows if w.start_s <= now < w.end_s), last)
        self.progress(current.name, now - first.start_s, last.end_s - first.start_s)
        if now + PROGRESS_PERIOD_S < last.end_s:
            self.world.clock.call_at(now + PROGRESS_PERIOD_S, self._report_progress)

    # --- results ------------------------------------------------------------------------------

    def _output(self) -> ThrottleOutput:
        return ThrottleOutput(self.robot.drive.limits, self.robot.drive.dac.vref_volts)

    def commands(self) -> tuple[list[SentCommand], list[SentCommand]]:
        """Every CAN movement command and every swept IBUS frame, with the volts it must set."""
        output, mapping = self._output(), self.robot.rc.mapping
        can_commands = [
            command
            for frame in self.movement_log.frames
            if (command := can_command(output, frame.timestamp_s, frame.data)) is not None
        ]
        rc_commands = [
            command
            for completed_s, channels in self.rc_sweep.frames
            if (command := rc_command(output, mapping, completed_s, channels)) is not None
        ]
        return can_commands, rc_commands

    def _result(
        self,
        window: PhaseWindow,
        can_commands: list[SentCommand],
        rc_commands: list[SentCommand],
    ) -> PhaseResult:
        tolerance_volts = self._output().tolerance_volts
        started, ended = window.started, window.ended
        if started is None or ended is None:
            raise RuntimeError(f"the {window.name} phase did not run to its end")
        duration_s = window.end_s - window.start_s
        wall_s = ended.wall_s - started.wall_s
        return PhaseResult(
            name=window.name,
            duration_s=duration_s,
            flood_load=window.flood_load,
            cpu_share=(ended.cpu_s - started.cpu_s) / wall_s,
            sim_cpu_share=(ended.sim_cpu_s - started.sim_cpu_s) / wall_s,
            bus_load=(ended.bus_bits - started.bus_bits) / self.world.bus.bitrate_bps / duration_s,
            can_latency=latency_in(can_commands, self.writes, window.can_span(), tolerance_volts),
            ibus_latency=latency_in(rc_commands, self.writes, window.rc_span(), tolerance_volts),
            tasks=tuple(TaskFigures.of(task, stats) for task, stats in window.task_stats),
            stops=stops_in(self.runtime.mode_log, (window.start_s + window.settle_s, window.end_s)),
            steal_share=(ended.steal_s - started.steal_s) / wall_s,
            cpu_pressure_share=(ended.pressure_s - started.pressure_s) / wall_s,
        )

    def _tail(
        self,
        clock: ProbedClock,
        window: PhaseWindow,
        can_commands: list[SentCommand],
        rc_commands: list[SentCommand],
    ) -> PhaseTail:
        tolerance_volts = self._output().tolerance_volts
        timeline = clock.timeline
        paths = (("can", can_commands, window.can_span()), ("ibus", rc_commands, window.rc_span()))
        tails = [
            explain_tail(
                timeline,
                path,
                latency_intervals(pairing_in(commands, self.writes, span, tolerance_volts)),
                TAIL_THRESHOLD_S,
            )
            for path, commands, span in paths
        ]
        span = (window.start_s, window.end_s)  # the whole phase, as the tasks' jitter figures
        tails.append(explain_tail(timeline, "wake", timeline.late_wakes(span), TAIL_THRESHOLD_S))
        return PhaseTail(window.name, tuple(gc_figures(timeline, span)), tuple(tails))


def _authenticate(world: SimWorld, robot: RobotConfig) -> SecocReceiver:
    """The computer signs and the controller verifies, with a key of the bench's own and
    freshness in memory (as a simulated run without a key file)."""
    key = simulated_run_key(replace(robot.security, enabled=False), robot.sim.seed)
    world.hlc.sign_with(sender_signer(key))
    return controller_receiver(replace(robot.security, freshness_file=None), key)
