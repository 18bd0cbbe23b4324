"""Actuator writes: output levels from the control step onto the hardware ports.

Every loop write goes through the `WriteGate`, so once the watchdog has tripped no loop write
reaches a port until the trip is acknowledged. DAC writes can fail (a NAK, a loose I2C cable):
failures are counted and flagged, and two rules turn them into a hardware fault (R-DAC-FAULT):

- a leaky count: each failed write adds 1, each good one takes `DAC_LEAK` away; reaching
  `dac_failure_limit` escalates, and the escalation holds until the count has drained to zero.
  Three failures in a row escalate; so does every other write failing (+0.75 a pair), which a
  count of *consecutive* failures never would;
- a failed write that should have *lowered* a channel's voltage: the DAC may still drive the
  old, higher voltage, so this alone is a fault until that channel is written successfully.

While either holds, the motors' enable line is driven low at once and stays low, and the
decision latches STOP (DAC_FAULT) until the operator re-arms.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.drive import DriveOutputs
from bywire.control.lights import LIGHT_LINES, LightOutputs
from bywire.errors import HardwareError
from bywire.hal.hardware import Hardware
from bywire.protocol import dac6574
from bywire.runtime.recent_fault import RecentFault
from bywire.runtime.write_gate import WriteGate

DAC_LEAK = 0.25  # one failure is forgiven after four good writes


@dataclass(frozen=True, slots=True)
class ActuatorConfig:
    """Where the analogue signals are and how faults escalate."""

    dac_throttle_channel: int = 0
    dac_regen_channel: int = 1
    dac_vref_volts: float = 5.0
    dac_failure_limit: int = 3  # failures in a row (30 ms at 100 Hz) before STOP
    safe_hydrobrake_duty: float = 1.0
    safe_steering_pulse_s: float = 0.0015


class Actuators:
    """Writes levels to the ports through the gate and keeps the DAC's health."""

    def __init__(self, hardware: Hardware, config: ActuatorConfig) -> None:
        self._hardware = hardware
        self._config = config
        self.dac_failures = RecentFault()
        self.dac_clamps = RecentFault()
        self.dac_failure_level = 0.0
        self._dac_escalated = False
        self._dac_volts: dict[int, float] = {}  # the last value each channel acknowledged
        self._dac_lowering_failed: set[int] = set()
        lines = hardware.outputs
        self.gate = WriteGate(
            {
                "motors_enable": lambda: lines.motors_enable.set(False),
                "motors_direction": lambda: self._write_direction(False, False),
                "dac": lambda: self._write_dac_pair(0.0, 0.0, None),
                "hydrobrake": lambda: self._write_brakes(config.safe_hydrobrake_duty, True),
                "steering": None,  # holds where it is
                "lights": self._write_lights_tripped,
            }
        )

    @property
    def dac_failing(self) -> bool:
        """The DAC cannot be trusted to drive what it was told (see the module's rules)."""
        return self._dac_escalated or bool(self._dac_lowering_failed)

    def acknowledged_volts(self, channel: int) -> float | None:
        """What `channel` was last told and acknowledged (None before its first good write)."""
        return self._dac_volts.get(channel)

    def write_steering(self, pulse_s: float) -> None:
        self.gate.write("steering", lambda: self._hardware.steering_pwm.set_pulse(pulse_s))

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
        self.gate.write("hydrobrake", lambda: self._write_brakes(hydrobrake_duty, ebrake_engaged))

    def write_lights(self, lights: LightOutputs) -> None:
        self.gate.write("lights", lambda: self._write_lights(lights))

    def write_safe(self, now: float, *, centre_steering: bool) -> None:
        """Every output to its de-energised state, past the gate; the DAC is tried but its failure
        cannot stop the rest. The steering is centred only when asked (at start-up): at any
        other time centring would be a swerve, so it holds."""
        self._hardware.outputs.all_low()
        self._write_brakes(self._config.safe_hydrobrake_duty, True)
        if centre_steering:
            self._hardware.steering_pwm.set_pulse(self._config.safe_steering_pulse_s)
        self.gate.write_safe("dac", lambda: self._write_dac_pair(0.0, 0.0, now))

    def watchdog_trip(self) -> None:
        """From the watchdog's thread: refuse the loop's writes and make every output safe."""
        self.gate.trip()

    # --- the ports ------------------------------------------------------------------------------

    def _write_direction(self, forward: bool, reverse: bool) -> None:
        lines = self._hardware.outputs
        lines.motors_forward.set(forward)
        lines.motors_reverse.set(reverse)

    def _write_brakes(self, hydrobrake_duty: float, ebrake_engaged: bool) -> None:
        pwm = self._hardware.hydrobrake_pwm
        pwm.set_pulse(hydrobrake_duty * pwm.period_s)
        self._hardware.outputs.ebrake_release.set(not ebrake_engaged)

    def _write_lights(self, lights: LightOutputs) -> None:
        lines = self._hardware.outputs
        for name, light in LIGHT_LINES:
            getattr(lines, light.line).set(getattr(lights, name))

    def _write_lights_tripped(self) -> None:
        """Each light's own safe level (`LightLine.tripped`): the error LED on, the rest held."""
        lines = self._hardware.outputs
        for _, light in LIGHT_LINES:
            if light.tripped is not None:
                getattr(lines, light.line).set(light.tripped)

    def _write_dac_pair(self, throttle_volts: float, regen_volts: float, now: float | None) -> None:
        self._write_dac(self._config.dac_throttle_channel, throttle_volts, now)
        self._write_dac(self._config.dac_regen_channel, regen_volts, now)

    def _write_dac(self, channel: int, volts: float, now: float | None) -> None:
        """One channel; `now` None for the safe writes, which only count towards health."""
        conversion = dac6574.code_from_volts(volts, self._config.dac_vref_volts)
        wanted = dac6574.volts_from_code(conversion.code, self._config.dac_vref_volts)
        if conversion.clamped and now is not None:
            self.dac_clamps.happened(now)
        try:
            self._hardware.dac.write(dac6574.encode_write(channel, conversion.code))
        except HardwareError:
            self._dac_failed(channel, wanted, now)
        else:
            self._dac_volts[channel] = wanted
            self._dac_lowering_failed.discard(channel)
            self.dac_failure_level = max(self.dac_failure_level - DAC_LEAK, 0.0)
            if self.dac_failure_level == 0.0:
                self._dac_escalated = False

    def _dac_failed(self, channel: int, wanted: float, now: float | None) -> None:
        if now is not None:
            self.dac_failures.happened(now)
        self.dac_failure_level = min(
            self.dac_failure_level + 1.0, 2.0 * self._config.dac_failure_limit
        )
        if self.dac_failure_level >= self._config.dac_failure_limit:
            self._dac_escalated = True
        if wanted < self._dac_volts.get(channel, 0.0):
            self._dac_lowering_failed.add(channel)
        if self.dac_failing:
            self._hardware.outputs.motors_enable.set(False)  # the safe direction: never gated
