"""The controller process: one loop that waits on the clock, reads inputs, decides and writes.

Each pass of the loop reads the clock once, then: reads every input port, takes the decision
once (if a periodic task is due, or an input arrived that can change it: `changes_decision`), and
writes each output at most once: the outputs of every due task, and whatever else the decision
changed, so that command to actuator latency is not bound to the 100 Hz tick and a STOP is
written whole at once, not at each output's own task rate. The writes go in the schedule table's
order, which is their order of importance: the brakes and the enable line before the slow I2C
transfers to the DAC. The same pass runs on the robot and on the simulator's virtual clock, so
the robot runs what the simulator ran. Periodic tasks keep absolute deadlines from the schedule
table. Every pass has a budget (`bywire.runtime.timing`): one that overruns it is a fault, and
only a pass that kept time feeds the watchdog. Outputs start safe and end safe, whatever
happens: the safe writes go on past any output that fails, and each failure is logged.

A task that raises (a bug, a port write that fails) ends the loop, and the process: continuing
on a state a half-finished pass left is no safe state. The exit path writes the safe outputs,
then sends one last ModeReport (STOP) and ErrorReport with TASK_CRASHED, so the higher-level
computer learns why the reports stop; the service manager restarts the process, in STOP.
"""

from __future__ import annotations

import gc
import logging
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from bywire.can_frame import CanFrame
from bywire.control.command_edges import NO_EDGES, CommandEdges
from bywire.control.command_slots import NO_COMMANDS, CommandSlots
from bywire.control.controller import (
    ControlInputs,
    ControlOutputs,
    ControlState,
    changes_decision,
    controller_step,
    trust_changed,
)
from bywire.control.rc_mapping import RcRequest
from bywire.control.supervisor import Cause
from bywire.control.validity import Stamped, age_s
from bywire.error_flags import ErrorFlag
from bywire.hal.hardware import Hardware
from bywire.model import Command, ControlCommand, ControlMode, MovementCommand
from bywire.protocol import dbc
from bywire.runtime.actuators import Actuators
from bywire.runtime.readers import CanReader, IbusReader
from bywire.runtime.recent_fault import RecentFault, active_flags
from bywire.runtime.reports import Health, build_reports, crash_reports
from bywire.runtime.schedule import PeriodicTask
from bywire.runtime.sensors import SensorReadings, read_sensors
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.timing import Overruns
from bywire.runtime.watchdog import Watchdog
from bywire.security.session import SecocReceiver
from bywire.task_table import TaskFn, TaskSpec

CycleObserver = Callable[[float], None]
MODE_LOG_LENGTH = 256  # mode changes kept for tools and tests; nothing grows with run time
log = logging.getLogger(__name__)


@dataclass(slots=True)
class _InputSlots:
    """The newest stamped input of each kind as the readers deliver it (the CAN commands' in
    one slot per command row), and arrival counts: the shell's own, updated in place; each
    decision copies them into one frozen ControlInputs."""

    rc: Stamped[RcRequest | None] | None = None
    commands: CommandSlots = NO_COMMANDS
    control_edges: CommandEdges = NO_EDGES
    rc_frames: int = 0
    control_frames: int = 0
    stop_requests: int = 0


class Runtime:
    """Runs the controller on a Hardware bundle until asked to stop or a time is reached."""

    def __init__(
        self,
        hardware: Hardware,
        config: RuntimeConfig,
        *,
        notify: Callable[[str], None] | None = None,
        watchdog_thread: bool = True,
        secoc: SecocReceiver | None = None,
    ) -> None:
        """`notify` receives systemd notifications (READY=1, WATCHDOG=1, STOPPING=1).

        `secoc`: authenticated commands ([security] on): the CAN reader's verifier.

        `watchdog_thread` False: the watchdog runs on the hardware clock and whoever owns that
        clock calls `watchdog.check()` (the simulator on virtual time does, every poll period).
        """
        self.hardware = hardware
        self.config = config
        self.clock = hardware.clock
        self.ibus = IbusReader(
            hardware.rc_uart,
            config.control.rc_mapping,
            config.control.supervisor.debounce_frames,
        )
        self.can = CanReader(hardware.can, config.rx_checks, secoc=secoc)
        self._announcement = () if secoc is None else secoc.announcement
        self.overruns = Overruns(config.actuators.budgets)
        self.actuators = Actuators(hardware, config.actuators, self.overruns)
        self.started_at = self.clock.now()
        self.tasks = [PeriodicTask(spec, self.started_at) for spec in config.schedule]
        self.state = ControlState()
        self.inputs = ControlInputs()
        """What the latest decision was taken on."""
        self.decided_at = self.started_at
        """When it was taken."""
        self._slots = _InputSlots()
        self.outputs: ControlOutputs | None = None
        self.sensors = SensorReadings()
        self.mode_log: deque[tuple[float, ControlMode]] = deque(maxlen=MODE_LOG_LENGTH)
        self.tx_faults = RecentFault()
        self.overrun_faults = RecentFault()
        self.reports_sent = 0
        self.on_cycle: list[CycleObserver] = []
        """Called with `now` after every pass of the loop, when every output of that instant
        has been written (the simulator observes the robot here)."""
        self._notify = notify
        self._watchdog_thread = watchdog_thread
        self.watchdog = (
            None
            if config.watchdog_s is None
            else Watchdog(
                self.actuators.watchdog_trip,
                config.watchdog_s,
                notify=notify,
                **({} if watchdog_thread else {"monotonic": self.clock.now}),
            )
        )
        self._flag_sources = (
            (self.ibus.checksum_faults, ErrorFlag.IBUS_CHECKSUM),
            (self.ibus.resync_faults, ErrorFlag.IBUS_RESYNC),
            (self.can.reject_faults, ErrorFlag.CAN_COMMAND_REJECTED),
            (self.can.auth_faults, ErrorFlag.CAN_AUTH_FAILED),
            (self.actuators.dac_failures, ErrorFlag.DAC_WRITE_FAILED),
            (self.actuators.dac_clamps, ErrorFlag.DAC_VALUE_CLAMPED),
            (self.tx_faults, ErrorFlag.CAN_TX_FAILED),
            (self.overrun_faults, ErrorFlag.TASK_OVERRUN),
            (self.overruns.recent, ErrorFlag.TASK_OVERRUN),
            # The ports' own failures: reported while they last, never acted on (the inputs'
            # timeouts stop the robot when a port delivers nothing).
            (self.can.link_faults.down, ErrorFlag.CAN_BUS_OFF),
            (self.can.link_faults.reopen_failed, ErrorFlag.CAN_OPEN_FAILED),
            (self.can.link_faults.receive_failed, ErrorFlag.CAN_RX_FAILED),
            (self.ibus.link_faults.down, ErrorFlag.IBUS_PORT_FAILED),
            (self.ibus.link_faults.reopen_failed, ErrorFlag.IBUS_PORT_FAILED),
            (self.ibus.link_faults.receive_failed, ErrorFlag.IBUS_PORT_FAILED),
        )
        self.crashed_by: Exception | None = None
        """What ended the loop when a task raised (TASK_CRASHED), else None."""
        self._stop_requested = False

    def request_stop(self) -> None:
        """End the loop at its next wake-up (signal handlers and the simulator call this)."""
        self._stop_requested = True

    def run(self, until_s: float | None = None) -> None:
        """Loop until `until_s` (clock time) or `request_stop`; outputs safe before and after."""
        self._write_safe("start-up", centre_steering=True)
        # Everything built so far lives as long as the process: keep it out of the collector's
        # full passes, which otherwise stall the loop for ~10 ms now and then (unless the robot
        # file says `gc_freeze = false`).
        if self.config.gc_freeze:
            gc.freeze()
        self._start_watchdog()
        try:
            while not self._stop_requested:
                now = self.clock.now()
                if until_s is not None and now >= until_s:
                    break
                on_time = self._pass(now)
                for observer in self.on_cycle:
                    observer(now)
                if self.watchdog is not None and on_time:
                    self.watchdog.feed()
                self.clock.wait_until(self._next_wake(until_s))
        except Exception as error:
            self.crashed_by = error
            raise
        finally:
            self._stop_watchdog()
            self._write_safe("exit", centre_steering=False)
            if self.crashed_by is not None:
                self._report_crash(self.crashed_by)

    def _report_crash(self, error: Exception) -> None:
        """After the safe writes, the last reports (`crash_reports`: STOP and TASK_CRASHED). The
        port may be what failed: a refusal or an error is logged, no more."""
        log.error("a task raised, the loop ends with every output safe: %r", error)
        now = self.clock.now()
        for report in crash_reports(self.outputs):
            frame_id, payload = dbc.encode_report(report)
            try:
                sent = self.hardware.can.send(CanFrame(frame_id, payload, now))
            except Exception as failure:  # whatever the port raises: the process is ending
                log.error("the last report (TASK_CRASHED) could not be sent: %r", failure)
                return
            if not sent:
                log.error("the last report (TASK_CRASHED) was refused by the CAN port")
                return

    def _write_safe(self, when: str, *, centre_steering: bool) -> None:
        """The safe state, every output tried; each one that failed is logged by name."""
        for failure in self.actuators.write_safe(self.clock.now(), centre_steering=centre_steering):
            log.error("safe state at %s: %s (every other output was still written)", when, failure)

    def _start_watchdog(self) -> None:
        if self.watchdog is not None:
            self.watchdog.feed()
            if self._watchdog_thread:
                self.watchdog.start()
        if self._notify is not None:
            self._notify("READY=1")

    def _stop_watchdog(self) -> None:
        if self._notify is not None:
            self._notify("STOPPING=1")
        if self.watchdog is not None and self._watchdog_thread:
            self.watchdog.stop()

    @property
    def overrun_count(self) -> int:
        return sum(task.stats.overruns for task in self.tasks)

    def _next_wake(self, until_s: float | None) -> float:
        deadline_s = min(task.next_deadline_s for task in self.tasks)
        return deadline_s if until_s is None else min(deadline_s, until_s)

    # --- one pass: read, decide, write --------------------------------------------------------

    def _pass(self, now: float) -> bool:
        """One pass at `now`; True when it kept time: it started within the pass budget of its
        earliest deadline and its last write landed within the budget (only then is the
        watchdog fed). A pass that overran is a timing fault."""
        new_input = self._poll_inputs(now) and self._news()
        due = [task for task in self.tasks if task.due(now)]
        if not (new_input or due):
            return True
        late_s = now - min(task.next_deadline_s for task in due) if due else 0.0
        started = time.perf_counter()
        before = self.outputs
        outputs = self._decide(now)
        decided_s = (time.perf_counter() - started) / max(len(due), 1)
        changed = _changed_writes((task.spec for task in self.tasks), before, outputs)
        for task in self.tasks:  # the table's order is the order of importance
            write = task.spec.run
            if not task.due(now):
                if write in changed:
                    write(self, outputs, now)
                continue
            started = time.perf_counter()
            write(self, outputs, now)
            spent_s = time.perf_counter() - started + decided_s
            task.stats.record(now - task.next_deadline_s, spent_s, task.spec.budget_s)
            overruns_before = task.stats.overruns
            task.advance(now)
            if task.stats.overruns > overruns_before:
                self.overrun_faults.happened(now)
        ended_s = self.clock.now()
        budget_s = self.overruns.budgets.pass_budget_s
        if self.overruns.check("pass", ended_s - now, budget_s, ended_s):
            return False
        self.overruns.on_time()
        return late_s <= budget_s

    # --- inputs -------------------------------------------------------------------------------

    def _poll_inputs(self, now: float) -> bool:
        """Read every input port into the slots; True when a new RC frame or CAN command arrived."""
        rc = self.ibus.poll(now)
        commands = self.can.poll(now)
        slots = self._slots
        if rc is not None:
            slots.rc = rc
            slots.rc_frames += 1
        for command in commands:
            self._store(command)
        stop_requested = self.can.stop_requests != slots.stop_requests
        slots.stop_requests = self.can.stop_requests
        return rc is not None or bool(commands) or stop_requested

    def _news(self) -> bool:
        """Whether what arrived can change the latest decision (`changes_decision`): a frame that
        only repeats a request waits for the next periodic decision, as time alone does."""
        return trust_changed(self.inputs, self.can.untrusted_kinds) or changes_decision(
            self.state, self.inputs, self.decided_at, self._slots, self.config.control
        )

    def _store(self, command: Stamped[Command]) -> None:
        slots = self._slots
        slots.commands = slots.commands.with_frames(command)
        if isinstance(command.value, ControlCommand):
            slots.control_edges = self.can.control_edges
            slots.control_frames += 1

    # --- the decision -------------------------------------------------------------------------

    def _decide(self, now: float) -> ControlOutputs:
        """Take the decision at `now`: once per pass, on the sensors read once."""
        self.sensors = sensors = read_sensors(self.hardware)
        watchdog_tripped = self.watchdog is not None and self.watchdog.tripped
        slots = self._slots
        self.inputs = ControlInputs(
            rc=slots.rc,
            commands=slots.commands,
            control_edges=slots.control_edges,
            rc_frames=slots.rc_frames,
            control_frames=slots.control_frames,
            stop_requests=slots.stop_requests,
            fault_flags=active_flags(self._flag_sources, now),
            dac_failing=self.actuators.dac_failing,
            watchdog_tripped=watchdog_tripped,
            untrusted=self.can.untrusted_kinds,
            timing_fault=self.overruns.active(),
            speed_mps=sensors.checked_speed_mps,
            hydrobrake_pressure_bar=sensors.checked_pressure_bar,
            steering_measured_norm=sensors.checked_steering_norm,
            estop_line_high=sensors.estop_line_high,
        )
        self.state, outputs = controller_step(self.state, self.inputs, now, self.config.control)
        self.decided_at = now
        if self.outputs is None or outputs.mode is not self.outputs.mode:
            self.mode_log.append((now, outputs.mode))
        self.outputs = outputs
        if watchdog_tripped and Cause.WATCHDOG not in outputs.causes:
            self._acknowledge_watchdog()
        return outputs

    def _acknowledge_watchdog(self) -> None:
        """The operator re-armed after a trip the decision saw: the loop may write again."""
        if self.watchdog is not None:
            self.watchdog.reset()
        self.actuators.gate.reset()

    def send_reports(self, outputs: ControlOutputs, now: float) -> None:
        """Send one full set of reports; on the first refusal give up until the next period.

        Backing off instead of retrying is the fix for §5.2: with the bus unplugged no mailbox
        ever frees, and a task that keeps retrying starves everything below it.
        """
        health = Health(
            uptime_s=now - self.started_at,
            overrun_count=self.overrun_count,
            rc_age_s=age_s(self.inputs.rc, now),
            can_age_s=age_s(self.inputs.commands.get(MovementCommand), now),
            wheel_speeds_mps=self.sensors.wheel_speeds_mps,
            steering_setpoint_norm=self.state.steering.setpoint_norm,
            steering_measured_norm=self.sensors.steering_measured_norm,
            encoder_valid_limit_norm=self.config.control.monitors.encoder_valid_limit_norm,
        )
        for report in build_reports(outputs, health):
            frame_id, payload = dbc.encode_report(report)
            if not self.hardware.can.send(CanFrame(frame_id, payload, now)):
                self.tx_faults.happened(now)
                return
            self.reports_sent += 1
        for frame_id, payload in self._announcement:  # SecOC: the trip counter senders sign in
            if not self.hardware.can.send(CanFrame(frame_id, payload, now)):
                self.tx_faults.happened(now)
                return


def _changed_writes(
    schedule: Iterable[TaskSpec], before: ControlOutputs | None, after: ControlOutputs
) -> frozenset[TaskFn]:
    """The writes whose outputs the decision changed (each row's `changed`): written at once,
    even where their task is not due: a STOP that time alone reveals, decided at a tick of the
    fastest task, engages the e-brake then, not at the brake task's own (slower) tick. The
    periodic tasks refresh everything anyway; an unchanged DAC value is not worth an I2C
    transfer."""
    return frozenset(
        spec.run
        for spec in schedule
        if spec.changed is not None and (before is None or spec.changed(before, after))
    )
