"""Actuator writes: output levels from the control step onto the hardware ports.

Every loop write goes through the `WriteGate`, so once the watchdog has tripped no loop write
reaches a port until the trip is acknowledged; the gate also times every write against its
budget (`bywire.runtime.timing`). DAC writes can fail (a NAK, a loose I2C cable) or crawl (a
slave stretching the clock): failures are counted and flagged, and three rules turn them into a
hardware fault (R-DAC-FAULT), by the pure rules of `bywire.control.dac_health`: a leaky count
of failed transfers, a failed write that should have lowered a voltage, and transfers slower than
their budget (each counts by the budgets it took); once the DAC is failing, the pass writes no
more DAC channels, so the loop is back on time sooner.

While any holds, the motors' enable line is driven low at once and stays low, and the decision
latches STOP (DAC_FAULT, category 0) until the operator re-arms.

`write_safe` writes every output's safe level in order of importance (enable, e-brake, hydraulic
brake, DAC, direction, lights, then the lines of the schedule's line tasks) and goes on past
any output that fails, reporting each: a dead lamp line must not leave the throttle at 4.75 V.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from bywire.config import DacOutput
from bywire.control.dac_health import DAC_FAILURE_LIMIT, DacHealth, Transfer, dac_step
from bywire.control.drive import DriveOutputs
from bywire.control.lights import LIGHT_LINES, LightOutputs
from bywire.errors import HardwareError
from bywire.hal.hardware import DigitalOutputs, Hardware
from bywire.protocol import dac6574
from bywire.runtime.recent_fault import RecentFault
from bywire.runtime.timing import Budgets, Overruns, overrun_weight
from bywire.runtime.write_gate import Action, WriteGate
from bywire.task_table import LINE_TASKS, TaskSpec

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class ActuatorConfig:
    """Where the analogue signals are and how faults escalate."""

    dac: DacOutput = field(default_factory=DacOutput)  # `[drive.dac]`: channels and Vref
    dac_failure_limit: int = DAC_FAILURE_LIMIT
    safe_hydrobrake_duty: float = 1.0
    safe_steering_pulse_s: float = 0.0015
    budgets: Budgets = field(default_factory=Budgets)
    line_tasks: tuple[TaskSpec, ...] = LINE_TASKS  # the schedule's rows that drive lines only


class Actuators:
    """Writes levels to the ports through the gate and keeps the DAC's health."""

    def __init__(
        self, hardware: Hardware, config: ActuatorConfig, overruns: Overruns | None = None
    ) -> None:
        self._hardware = hardware
        self._config = config
        self._now = hardware.clock.now
        self.overruns = overruns if overruns is not None else Overruns(config.budgets)
        self.safe_failures: tuple[str, ...] = ()
        """What the latest `write_safe` could not write, one line each."""
        self._hold_pulse_s: float | None = None  # the commanded steering, without boost
        self._slow_transfer = False  # a DAC transfer of this write overran its budget
        self._dac_error: str | None = None  # why the DAC's last write failed (None: it did not)
        self.dac_failures = RecentFault()
        self.dac_clamps = RecentFault()
        self.dac_health = DacHealth()
        lines = hardware.outputs
        self.gate = WriteGate(
            {  # in order of importance: the watchdog makes them safe in this order
                "motors_enable": lambda: lines.motors_enable.set(False),
                "ebrake": lambda: lines.ebrake_release.set(False),
                "hydrobrake": lambda: self._write_hydrobrake(config.safe_hydrobrake_duty),
                "dac": lambda: self._write_dac_pair(0.0, 0.0, None),
                "motors_direction": lambda: _each(self._direction_writes(False, False)),
                "lights": lambda: _each(self._tripped_light_writes()),
                **{task.name: _lines_low(lines, task.lines) for task in config.line_tasks},
                "steering": self._hold_steering,  # the commanded position: a swerve otherwise
            },
            now=self._now,
            overruns=self.overruns,
            untimed=("dac",),  # timed per transfer (`_write_dac`)
        )

    @property
    def dac_failing(self) -> bool:
        """The DAC cannot be trusted to drive what it was told (see the module's rules)."""
        return self.dac_health.failing

    @property
    def dac_failure_level(self) -> float:
        return self.dac_health.level

    def acknowledged_volts(self, channel: int) -> float | None:
        """What `channel` was last told and acknowledged (None before its first good write)."""
        return self.dac_health.volts(channel)

    def write_steering(self, pulse_s: float, hold_pulse_s: float | None = None) -> None:
        """`pulse_s` (boosted, perhaps); `hold_pulse_s` is the commanded position without the
        boost, which the watchdog holds if it trips (default: `pulse_s`)."""
        hold_s = pulse_s if hold_pulse_s is None else hold_pulse_s

        def write() -> None:  # the hold changes only with a write the gate lets through
            self._hold_pulse_s = hold_s
            self._hardware.steering_pwm.set_pulse(pulse_s)

        self.gate.write("steering", write)

    def write_drive(self, drive: DriveOutputs, now: float) -> None:
        """Table 2's signals; the enable line goes low first and high last."""
        enable = self._hardware.outputs.motors_enable
        if not drive.enable or self.dac_failing:
            self.gate.write("motors_enable", lambda: enable.set(False))
        self.gate.write(
            "motors_direction", lambda: self._write_direction(drive.forward, drive.reverse)
        )
        self.gate.write(
            "dac", lambda: self._write_dac_pair(drive.throttle_volts, drive.regen_volts, now)
        )
        if drive.enable and not self.dac_failing:
            self.gate.write("motors_enable", lambda: enable.set(True))

    def write_brakes(self, hydrobrake_duty: float, ebrake_engaged: bool) -> None:
        """The spring brake's line first, then the hydraulic brake's duty."""
        release = self._hardware.outputs.ebrake_release
        self.gate.write("ebrake", lambda: release.set(not ebrake_engaged))
        self.gate.write("hydrobrake", lambda: self._write_hydrobrake(hydrobrake_duty))

    def write_lights(self, lights: LightOutputs) -> None:
        self.gate.write("lights", lambda: self._write_lights(lights))

    def write_lines(self, task: str, levels: Mapping[str, bool]) -> None:
        """A line task's levels (`TaskSpec.lines`), through the gate under the task's name."""
        lines = self._hardware.outputs
        self.gate.write(task, lambda: _each([(n, _setter(lines, n, v)) for n, v in levels.items()]))

    def write_safe(self, now: float, *, centre_steering: bool) -> tuple[str, ...]:
        """Every output to its de-energised state, past the gate, in order of importance (enable,
        e-brake, hydraulic brake, DAC, direction, lights), each tried whatever failed before
        it; returns (and keeps in `safe_failures`) what could not be written, one line each.
        The steering is centred only when asked (at start-up): at any other time centring
        would be a swerve, so it holds."""
        lines, config = self._hardware.outputs, self._config
        writes: list[tuple[str, str, Action]] = [
            ("motors_enable", "motors_enable", lambda: lines.motors_enable.set(False)),
            ("ebrake", "ebrake_release", lambda: lines.ebrake_release.set(False)),
            (
                "hydrobrake",
                "hydrobrake",
                lambda: self._write_hydrobrake(config.safe_hydrobrake_duty),
            ),
            *(
                ("dac", f"DAC channel {channel}", self._safe_dac(channel, now))
                for channel in (config.dac.throttle_channel, config.dac.regen_channel)
            ),
            *(
                ("motors_direction", name, write)
                for name, write in self._direction_writes(False, False)
            ),
            *(("lights", light.line, _low(lines, light.line)) for _, light in LIGHT_LINES),
            *(
                (task.name, line, _low(lines, line))
                for task in config.line_tasks
                for line in task.lines
            ),
        ]
        if centre_steering:
            pulse_s = config.safe_steering_pulse_s
            writes.append(
                ("steering", "steering", lambda: self._hardware.steering_pwm.set_pulse(pulse_s))
            )
        failures = []
        for port, name, write in writes:
            try:
                self.gate.write_safe(port, write)
            except Exception as error:
                failures.append(f"{name}: {error or type(error).__name__}")
        self.safe_failures = tuple(failures)
        return self.safe_failures

    def watchdog_trip(self) -> None:
        """From the watchdog's thread: refuse the loop's writes and make every output safe."""
        self.gate.trip()

    # --- the ports ------------------------------------------------------------------------------

    def _direction_writes(self, forward: bool, reverse: bool) -> list[tuple[str, Action]]:
        lines = self._hardware.outputs
        return [
            ("motors_forward", lambda: lines.motors_forward.set(forward)),
            ("motors_reverse", lambda: lines.motors_reverse.set(reverse)),
        ]

    def _write_direction(self, forward: bool, reverse: bool) -> None:
        lines = self._hardware.outputs
        lines.motors_forward.set(forward)
        lines.motors_reverse.set(reverse)

    def _write_hydrobrake(self, duty: float) -> None:
        pwm = self._hardware.hydrobrake_pwm
        pwm.set_pulse(duty * pwm.period_s)

    def _hold_steering(self) -> None:
        """The watchdog's steering: the last commanded position, not a boosted pulse."""
        if self._hold_pulse_s is not None:
            self._hardware.steering_pwm.set_pulse(self._hold_pulse_s)

    def _write_lights(self, lights: LightOutputs) -> None:
        lines = self._hardware.outputs
        for name, light in LIGHT_LINES:
            lines.line(light.line).set(getattr(lights, name))

    def _tripped_light_writes(self) -> list[tuple[str, Action]]:
        """Each light's own safe level (`LightLine.tripped`): the error LED on, the rest held."""
        lines = self._hardware.outputs
        return [
            (light.line, _setter(lines, light.line, light.tripped))
            for _, light in LIGHT_LINES
            if light.tripped is not None
        ]

    def _safe_dac(self, channel: int, now: float) -> Action:
        def write() -> None:
            self._write_dac(channel, 0.0, now)
            if self.dac_health.volts(channel) != 0.0:  # a slow transfer that landed counts
                raise HardwareError("0 V not acknowledged")

        return write

    def _write_dac_pair(self, throttle_volts: float, regen_volts: float, now: float | None) -> None:
        self._slow_transfer = False
        self._write_dac(self._config.dac.throttle_channel, throttle_volts, now)
        if self._slow_transfer and now is not None:
            return  # the loop's write: no more crawling transfers in this pass
        self._write_dac(self._config.dac.regen_channel, regen_volts, now)

    def _write_dac(self, channel: int, volts: float, now: float | None) -> bool:
        """One channel; `now` None for the watchdog's safe writes, which only count towards
        health. True when the transfer was acknowledged within its budget."""
        conversion = dac6574.code_from_volts(volts, self._config.dac.vref_volts)
        wanted = dac6574.volts_from_code(conversion.code, self._config.dac.vref_volts)
        if conversion.clamped and now is not None:
            self.dac_clamps.happened(now)
        started_s = self._now()
        try:
            self._hardware.dac.write(dac6574.encode_write(channel, conversion.code))
        except HardwareError as error:
            self._dac_failed_because(str(error))
            self._dac_went(channel, wanted, Transfer.FAILED, 1.0, now)
            return False
        ended_s = self._now()
        budget_s = self._config.budgets.dac_transfer_budget_s
        if self.overruns.check("DAC transfer", ended_s - started_s, budget_s, ended_s):
            weight = overrun_weight(ended_s - started_s, budget_s)
            self._dac_went(channel, wanted, Transfer.SLOW, weight, now)
            self._slow_transfer = self.dac_failing
            return False
        self._dac_went(channel, wanted, Transfer.ACKNOWLEDGED, 1.0, now)
        if self.dac_failure_level == 0.0:
            self._dac_error = None  # healthy again: the next failure is news
        return True

    def _dac_failed_because(self, reason: str) -> None:
        """Log why a DAC write failed, once until the DAC is healthy again or the reason changes
        (the flags count the failures; the log says why: an address that stopped answering)."""
        if reason != self._dac_error:
            log.warning("DAC write failed: %s", reason)
            self._dac_error = reason

    def _dac_went(
        self, channel: int, wanted: float, transfer: Transfer, weight: float, now: float | None
    ) -> None:
        limit = self._config.dac_failure_limit
        self.dac_health = dac_step(
            self.dac_health, channel, wanted, transfer, limit=limit, weight=weight
        )
        if transfer is not Transfer.ACKNOWLEDGED and now is not None:
            self.dac_failures.happened(now)
        if self.dac_failing:
            self._hardware.outputs.motors_enable.set(False)  # the safe direction: never gated


def _each(writes: Sequence[tuple[str, Action]]) -> None:
    """Every write tried, whatever fails; then HardwareError naming each one that failed."""
    failed = []
    for name, write in writes:
        try:
            write()
        except Exception as error:
            failed.append(f"{name}: {error or type(error).__name__}")
    if failed:
        raise HardwareError("; ".join(failed))


def _setter(lines: DigitalOutputs, line: str, level: bool) -> Action:
    output = lines.line(line)
    return lambda: output.set(level)


def _low(lines: DigitalOutputs, line: str) -> Action:
    return _setter(lines, line, False)


def _lines_low(lines: DigitalOutputs, names: Sequence[str]) -> Action:
    return lambda: _each([(name, _low(lines, name)) for name in names])
