"""The simulated robot's body: samples the actuator outputs every step and moves the vehicle model.

Wiring: throttle and regenerative-brake volts from two DAC6574 channels, the motor enable and
direction lines, the e-brake release line (low = engaged), the hydraulic-brake PWM duty and the
steering servo pulse. The wheel-speed sensor reads the model's left and right wheel speeds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from bywire.hal.simulated.dac import SimDac6574
from bywire.hal.simulated.gpio_pwm import SimDigitalOut, SimPwmChannel
from bywire.hal.simulated.timers import PeriodicTimer, SimClock
from bywire.hal.simulated.vehicle_model import (
    ActuatorInputs,
    VehicleConfig,
    VehicleModel,
    VehicleState,
)

DEFAULT_STEP_S = 0.005
DEFAULT_HISTORY_LIMIT = 12_000  # one minute of states at 200 Hz


@dataclass(frozen=True, slots=True)
class VehicleWiring:
    """The outputs the vehicle reads, and which DAC channel carries which analogue signal."""

    dac: SimDac6574
    motors_enable: SimDigitalOut
    motors_forward: SimDigitalOut
    motors_reverse: SimDigitalOut
    ebrake_release: SimDigitalOut
    steering_pwm: SimPwmChannel
    hydrobrake_pwm: SimPwmChannel
    throttle_channel: int = 0
    regen_channel: int = 1

    def throttle_volts(self) -> float:
        """The volts on the motor controllers' throttle input (the DAC channel wired to it)."""
        return self.dac.volts(self.throttle_channel)

    def regen_volts(self) -> float:
        """The volts on the motor controllers' regenerative brake input."""
        return self.dac.volts(self.regen_channel)

    def sample(self, faults: ActuatorFaults) -> ActuatorInputs:
        """The actuator inputs at this instant, as broken actuators pass them on."""
        return ActuatorInputs(
            throttle_volts=self.throttle_volts(),
            regen_volts=self.regen_volts(),
            motors_enable=self.motors_enable.level,
            motors_forward=self.motors_forward.level,
            motors_reverse=self.motors_reverse.level,
            ebrake_release=self.ebrake_release.level or faults.ebrake_failed,
            hydraulic_duty=0.0 if faults.hydrobrake_failed else self.hydrobrake_pwm.duty,
            steering_pulse_s=0.0 if faults.servo_stuck else self.steering_pwm.pulse_s,
        )


@dataclass(slots=True)
class ActuatorFaults:
    """Broken actuators (Table 4): a brake that does not brake, a servo that does not move."""

    hydrobrake_failed: bool = False  # no pressure builds, no hydraulic braking
    ebrake_failed: bool = False  # the spring brake does not engage
    servo_stuck: bool = False  # the steering servo stays where it is


class SimVehicle:
    """Runs ``VehicleModel`` every ``step_s`` on the clock; ``history`` keeps recent states."""

    def __init__(
        self,
        clock: SimClock,
        wiring: VehicleWiring,
        config: VehicleConfig | None = None,
        step_s: float = DEFAULT_STEP_S,
        history_limit: int | None = DEFAULT_HISTORY_LIMIT,
    ) -> None:
        self.wiring = wiring
        self.model = VehicleModel(config or VehicleConfig())
        self.state = VehicleState()
        self.inputs = ActuatorInputs()
        self.faults = ActuatorFaults()
        self.grade = 0.0  # the road's rise over run, forward; a scenario's `world` action sets it
        self.history: deque[tuple[float, VehicleState]] = deque(maxlen=history_limit)
        """``(time_s, state)`` after each step, the latest ``history_limit`` of them."""
        self._clock = clock
        self._step_s = step_s
        self._timer = PeriodicTimer(clock, step_s, self._step)

    def start(self, first_s: float | None = None) -> None:
        """Run from ``first_s`` (default now): each step ends ``step_s`` later.

        A step integrates the ``step_s`` that just ended with the actuators as they are at its
        end, so ``(time_s, state)`` in ``history`` is the state at ``time_s``.
        """
        start_s = self._clock.now() if first_s is None else first_s
        self._timer.start(start_s + self._step_s)

    def stop(self) -> None:
        """Freeze the vehicle."""
        self._timer.stop()

    def wheel_speeds(self) -> tuple[float, float]:
        """(left_mps, right_mps) now, positive forward."""
        return self.model.wheel_speeds(self.state)

    def _step(self, tick_s: float) -> None:
        self.inputs = self.wiring.sample(self.faults)
        self.state = self.model.step(self.state, self.inputs, self._step_s, self.grade)
        self.history.append((tick_s, self.state))


class SimWheelSpeedSensor:
    """A ``WheelSpeedSensor`` on the simulated vehicle; ``fail()`` makes it read None, ``die()``
    makes it read 0 while the wheels turn (a sensor that dies quietly)."""

    def __init__(self, vehicle: SimVehicle) -> None:
        self._vehicle = vehicle
        self.failed = False
        self.dead = False

    def read(self) -> tuple[float, float] | None:
        if self.failed:
            return None
        return (0.0, 0.0) if self.dead else self._vehicle.wheel_speeds()

    def fail(self) -> None:
        """The sensor stops answering."""
        self.failed = True

    def die(self) -> None:
        """The sensor answers 0 m/s from now on, whatever the wheels do."""
        self.dead = True

    def restore(self) -> None:
        """The sensor answers again, and tells the truth."""
        self.failed = self.dead = False


class SimPressureSensor:
    """Hydraulic brake pressure in bar: proportional to the duty the brake really applies."""

    def __init__(self, vehicle: SimVehicle, full_scale_bar: float = 10.0) -> None:
        self._vehicle = vehicle
        self._full_scale_bar = full_scale_bar

    def read(self) -> float | None:
        return self._vehicle.inputs.hydraulic_duty * self._full_scale_bar


class SimSteeringEncoder:
    """The steering angle the servo really reached, −1…1; `fail()` makes it read None."""

    def __init__(self, vehicle: SimVehicle) -> None:
        self._vehicle = vehicle
        self.failed = False

    def read(self) -> float | None:
        return None if self.failed else self._vehicle.state.steering_norm
