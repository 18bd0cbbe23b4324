"""Actuator writes: output levels from the control step onto the hardware ports.

Each task writes its own actuators. DAC writes can fail (a NAK, a loose I2C cable): failures are
counted and flagged, and a run of consecutive failures becomes a hardware fault that the control
step turns into STOP with the motors disabled through the enable GPIO (R-DAC-FAULT).
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.drive import DriveOutputs
from bywire.control.lights import LightOutputs
from bywire.errors import HardwareError
from bywire.hal.hardware import Hardware
from bywire.protocol import dac6574
from bywire.runtime.readers import RecentFault


@dataclass(frozen=True, slots=True)
class ActuatorConfig:
    """Where the analogue signals are and how faults escalate."""

    dac_throttle_channel: int = 0
    dac_regen_channel: int = 1
    dac_vref_volts: float = 5.0
    dac_failure_limit: int = 3  # consecutive failed writes (30 ms at 100 Hz) before STOP
    safe_hydrobrake_duty: float = 1.0
    safe_steering_pulse_s: float = 0.0015


class Actuators:
    """Writes levels to the ports and keeps the DAC's health."""

    def __init__(self, hardware: Hardware, config: ActuatorConfig) -> None:
        self._hardware = hardware
        self._config = config
        self.dac_failures = RecentFault()
        self.dac_clamps = RecentFault()
        self.consecutive_dac_failures = 0
        self._dac_fault = False

    @property
    def dac_fault(self) -> bool:
        """True from the `dac_failure_limit`-th failed write in a row until acknowledged: one good
        write in between must not re-enable the motors of an intermittent DAC."""
        return self._dac_fault

    def acknowledge_dac_fault(self) -> bool:
        """The operator acknowledged (mode switch to STOP): clear the fault if the DAC has
        answered since. True when cleared."""
        if self.consecutive_dac_failures == 0:
            self._dac_fault = False
        return not self._dac_fault

    def write_steering(self, pulse_s: float) -> None:
        self._hardware.steering_pwm.set_pulse(pulse_s)

    def write_drive(self, drive: DriveOutputs, now: float) -> None:
        """Table 2's signals; the enable line goes low first and high last."""
        lines = self._hardware.outputs
        if not drive.enable:
            lines.motors_enable.set(False)
        lines.motors_forward.set(drive.forward)
        lines.motors_reverse.set(drive.reverse)
        self._write_dac(self._config.dac_throttle_channel, drive.throttle_volts, now)
        self._write_dac(self._config.dac_regen_channel, drive.regen_volts, now)
        if drive.enable and not self.dac_fault:
            lines.motors_enable.set(True)

    def write_brakes(self, hydrobrake_duty: float, ebrake_engaged: bool) -> None:
        pwm = self._hardware.hydrobrake_pwm
        pwm.set_pulse(hydrobrake_duty * pwm.period_s)
        self._hardware.outputs.ebrake_release.set(not ebrake_engaged)

    def write_lights(self, lights: LightOutputs) -> None:
        lines = self._hardware.outputs
        lines.brake_light.set(lights.brake)
        lines.reverse_light.set(lights.reverse)
        lines.turn_left_light.set(lights.turn_left)
        lines.turn_right_light.set(lights.turn_right)
        lines.low_beam.set(lights.low_beam)
        lines.error_led.set(lights.error_led)

    def write_safe(self, now: float) -> None:
        """Every output to its safe state; the DAC is tried but its failure cannot stop the rest."""
        self._hardware.outputs.all_low()
        self.write_brakes(self._config.safe_hydrobrake_duty, ebrake_engaged=True)
        self.write_steering(self._config.safe_steering_pulse_s)
        self._write_dac(self._config.dac_throttle_channel, 0.0, now)
        self._write_dac(self._config.dac_regen_channel, 0.0, now)

    def _write_dac(self, channel: int, volts: float, now: float) -> None:
        conversion = dac6574.code_from_volts(volts, self._config.dac_vref_volts)
        if conversion.clamped:
            self.dac_clamps.happened(now)
        try:
            self._hardware.dac.write(dac6574.encode_write(channel, conversion.code))
        except HardwareError:
            self.dac_failures.happened(now)
            self.consecutive_dac_failures += 1
            if self.consecutive_dac_failures >= self._config.dac_failure_limit:
                self._dac_fault = True
                self._hardware.outputs.motors_enable.set(False)
        else:
            self.consecutive_dac_failures = 0
