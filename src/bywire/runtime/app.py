"""The controller process: one loop that waits on the clock, reads inputs, and runs the schedule.

Inputs are event-driven: when the clock wakes the loop because bytes or frames arrived, they are
read at once and, if they carry a new command, the decision is taken and steering, drive and
brakes are written immediately, so command-to-actuator latency is not bound to the 100 Hz tick.
Periodic tasks run on absolute deadlines from the schedule table and re-take the decision, so
input ages are checked every control cycle. Outputs start safe and end safe, whatever happens.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable
from dataclasses import replace

from bywire.control.controller import (
    ControlInputs,
    ControlOutputs,
    ControlState,
    controller_step,
)
from bywire.control.error_flags import ErrorFlag
from bywire.control.validity import Stamped, age_s
from bywire.hal.hardware import Hardware
from bywire.hal.ports import CanFrame
from bywire.model import Command, ControlCommand, ControlMode, LightsCommand, MovementCommand
from bywire.protocol import dbc
from bywire.runtime.actuators import Actuators
from bywire.runtime.readers import CanReader, IbusReader, RecentFault
from bywire.runtime.reports import Health, build_reports
from bywire.runtime.schedule import PeriodicTask
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import Watchdog

CycleObserver = Callable[[float], None]


class Runtime:
    """Runs the controller on a Hardware bundle until asked to stop or a time is reached."""

    def __init__(
        self,
        hardware: Hardware,
        config: RuntimeConfig,
        *,
        notify: Callable[[str], None] | None = None,
    ) -> None:
        """`notify` receives systemd notifications (READY=1, WATCHDOG=1, STOPPING=1)."""
        self.hardware = hardware
        self.config = config
        self.clock = hardware.clock
        self.ibus = IbusReader(hardware.rc_uart, config.control.rc_mapping)
        self.can = CanReader(hardware.can)
        self.actuators = Actuators(hardware, config.actuators)
        self.started_at = self.clock.now()
        self.tasks = [PeriodicTask(spec, self.started_at) for spec in config.schedule]
        self.state = ControlState()
        self.inputs = ControlInputs()
        self.outputs: ControlOutputs | None = None
        self.mode_log: list[tuple[float, ControlMode]] = []
        self.tx_faults = RecentFault()
        self.overrun_faults = RecentFault()
        self.reports_sent = 0
        self.on_cycle: list[CycleObserver] = []
        """Called with `now` after every pass of the loop, when every output of that instant
        has been written (the simulator observes the robot here)."""
        self._stepped_at: float | None = None
        self._notify = notify
        self.watchdog = (
            None
            if config.watchdog_s is None
            else Watchdog(self._watchdog_trip, config.watchdog_s, notify=notify)
        )
        self._stop_requested = False
        self._actions: dict[str, Callable[[float], None]] = {
            "steering": self._steering_task,
            "driving": self._driving_task,
            "hydrobrake": self._hydrobrake_task,
            "can_tx": self._can_tx_task,
            "lights": self._lights_task,
        }

    def request_stop(self) -> None:
        """End the loop at its next wake-up (signal handlers and the simulator call this)."""
        self._stop_requested = True

    def run(self, until_s: float | None = None) -> None:
        """Loop until `until_s` (clock time) or `request_stop`; outputs safe before and after."""
        self.actuators.write_safe(self.clock.now())
        # Everything built so far lives as long as the process: keep it out of the collector's
        # full passes, which otherwise stall the loop for ~10 ms now and then.
        gc.freeze()
        self._start_watchdog()
        try:
            while not self._stop_requested:
                now = self.clock.now()
                if until_s is not None and now >= until_s:
                    break
                self._poll_inputs(now)
                self._run_due_tasks()
                for observer in self.on_cycle:
                    observer(now)
                if self.watchdog is not None:
                    self.watchdog.feed()
                self.clock.wait_until(self._next_wake(until_s))
        finally:
            self._stop_watchdog()
            self.actuators.write_safe(self.clock.now())

    def _start_watchdog(self) -> None:
        if self.watchdog is not None:
            self.watchdog.start()
        if self._notify is not None:
            self._notify("READY=1")

    def _stop_watchdog(self) -> None:
        if self._notify is not None:
            self._notify("STOPPING=1")
        if self.watchdog is not None:
            self.watchdog.stop()

    def _watchdog_trip(self) -> None:
        """From the watchdog's thread: the loop is stuck, so write the safe outputs here."""
        self.actuators.write_safe(self.clock.now())

    @property
    def overrun_count(self) -> int:
        return sum(task.stats.overruns for task in self.tasks)

    def _next_wake(self, until_s: float | None) -> float:
        deadline_s = min(task.next_deadline_s for task in self.tasks)
        return deadline_s if until_s is None else min(deadline_s, until_s)

    # --- inputs -------------------------------------------------------------------------------

    def _poll_inputs(self, now: float) -> None:
        rc = self.ibus.poll(now)
        commands = self.can.poll(now)
        if rc is not None:
            self.inputs = replace(self.inputs, rc=rc)
        for command in commands:
            self._store(command)
        if rc is not None or commands:
            before = self.outputs
            self._write_changes(before, self._decide(now, force=True), now)

    def _write_changes(
        self, before: ControlOutputs | None, after: ControlOutputs, now: float
    ) -> None:
        """Write at once what a new input changed. The periodic tasks refresh everything anyway;
        an unchanged DAC value is not worth an I2C transfer 140 times a second."""
        if before is None or after.steering_pulse_s != before.steering_pulse_s:
            self.actuators.write_steering(after.steering_pulse_s)
        if before is None or after.drive != before.drive:
            self.actuators.write_drive(after.drive, now)
        brakes = (after.hydrobrake_duty, after.ebrake_engaged)
        if before is None or brakes != (before.hydrobrake_duty, before.ebrake_engaged):
            self.actuators.write_brakes(*brakes)

    def _store(self, command: Stamped[Command]) -> None:
        value = command.value
        if isinstance(value, MovementCommand):
            self.inputs = replace(self.inputs, movement=Stamped(value, command.received_at))
        elif isinstance(value, LightsCommand):
            self.inputs = replace(self.inputs, lights=Stamped(value, command.received_at))
        elif isinstance(value, ControlCommand):
            self.inputs = replace(self.inputs, control=Stamped(value, command.received_at))

    # --- the decision -------------------------------------------------------------------------

    def _shell_flags(self, now: float) -> ErrorFlag:
        sources = (
            (self.ibus.checksum_faults, ErrorFlag.IBUS_CHECKSUM),
            (self.ibus.resync_faults, ErrorFlag.IBUS_RESYNC),
            (self.can.reject_faults, ErrorFlag.CAN_COMMAND_REJECTED),
            (self.actuators.dac_failures, ErrorFlag.DAC_WRITE_FAILED),
            (self.actuators.dac_clamps, ErrorFlag.DAC_VALUE_CLAMPED),
            (self.tx_faults, ErrorFlag.CAN_TX_FAILED),
            (self.overrun_faults, ErrorFlag.TASK_OVERRUN),
        )
        flags = ErrorFlag(0)
        for fault, flag in sources:
            if fault.active(now):
                flags |= flag
        if self.actuators.dac_fault:
            flags |= ErrorFlag.DAC_FAULT_STOP
        if self.watchdog is not None and self.watchdog.tripped:
            flags |= ErrorFlag.WATCHDOG_TRIPPED
        return flags

    def _decide(self, now: float, *, force: bool = False) -> ControlOutputs:
        """Take the decision at `now` (once per instant unless new input forces it)."""
        if self.outputs is not None and self._stepped_at == now and not force:
            return self.outputs
        self._acknowledge_faults()
        speed_mps, pressure_bar, steering_norm = self._sensor_readings()
        self.inputs = replace(
            self.inputs,
            fault_flags=int(self._shell_flags(now)),
            hardware_fault=self.actuators.dac_fault
            or (self.watchdog is not None and self.watchdog.tripped),
            speed_mps=speed_mps,
            hydrobrake_pressure_bar=pressure_bar,
            steering_measured_norm=steering_norm,
        )
        self.state, outputs = controller_step(self.state, self.inputs, now, self.config.control)
        if self.outputs is None or outputs.mode is not self.outputs.mode:
            self.mode_log.append((now, outputs.mode))
        self.outputs, self._stepped_at = outputs, now
        return outputs

    def _sensor_readings(self) -> tuple[float | None, float | None, float | None]:
        """Speed, brake pressure and steering angle now (None where no sensor is fitted)."""
        hardware = self.hardware
        wheels = None if hardware.wheel_speeds is None else hardware.wheel_speeds.read()
        pressure, encoder = hardware.hydrobrake_pressure_bar, hardware.steering_encoder_norm
        return (
            None if wheels is None else (wheels[0] + wheels[1]) / 2,
            None if pressure is None else pressure.read(),
            None if encoder is None else encoder.read(),
        )

    def _acknowledge_faults(self) -> None:
        """Hardware faults (watchdog, DAC) are acknowledged by moving the mode switch to STOP."""
        rc = self.inputs.rc
        if rc is None or rc.value is None or rc.value.mode is not ControlMode.STOP:
            return
        if self.watchdog is not None and self.watchdog.tripped:
            self.watchdog.reset()
        if self.actuators.dac_fault:
            self.actuators.acknowledge_dac_fault()

    # --- periodic tasks -----------------------------------------------------------------------

    def _run_due_tasks(self) -> None:
        for task in self.tasks:
            now = self.clock.now()
            if not task.due(now):
                continue
            started = time.perf_counter()
            self._actions[task.spec.name](now)
            spent_s = time.perf_counter() - started
            task.stats.record(now - task.next_deadline_s, spent_s, task.spec.budget_s)
            overruns_before = task.stats.overruns
            task.advance(self.clock.now())
            if task.stats.overruns > overruns_before:
                self.overrun_faults.happened(now)

    def _steering_task(self, now: float) -> None:
        self.actuators.write_steering(self._decide(now).steering_pulse_s)

    def _driving_task(self, now: float) -> None:
        self.actuators.write_drive(self._decide(now).drive, now)

    def _hydrobrake_task(self, now: float) -> None:
        outputs = self._decide(now)
        self.actuators.write_brakes(outputs.hydrobrake_duty, outputs.ebrake_engaged)

    def _lights_task(self, now: float) -> None:
        self.actuators.write_lights(self._decide(now).lights)

    def _can_tx_task(self, now: float) -> None:
        """Send one full set of reports; on the first refusal give up until the next period.

        Backing off instead of retrying is the fix for §5.2: with the bus unplugged no mailbox
        ever frees, and a task that keeps retrying starves everything below it.
        """
        sensor = self.hardware.wheel_speeds
        health = Health(
            uptime_s=now - self.started_at,
            overrun_count=self.overrun_count,
            rc_age_s=age_s(self.inputs.rc, now),
            can_age_s=age_s(self.inputs.movement, now),
            wheel_speeds_mps=None if sensor is None else sensor.read(),
            steering_setpoint_norm=self.state.steering.setpoint_norm,
        )
        for report in build_reports(self._decide(now), health):
            frame_id, payload = dbc.encode_report(report)
            if not self.hardware.can.send(CanFrame(frame_id, payload, now)):
                self.tx_faults.happened(now)
                return
            self.reports_sent += 1
