"""What a scenario can see of the simulated robot at one instant, and its expectation conditions.

Observations read the simulated hardware (DAC volts, GPIO levels, PWM duty, the vehicle), not the
controller's intentions, so "safe within 110 ms" means the outputs really were safe.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from bywire.control.controller import ControlOutputs
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, Gear


@dataclass(frozen=True, slots=True)
class Observation:
    """The robot at `time_s`: commands chosen, actuator outputs, vehicle and lamps."""

    time_s: float
    mode: ControlMode
    latched: bool
    gear: Gear
    steering_cmd_norm: float
    throttle_cmd_norm: float
    brake_cmd_norm: float
    steering_pulse_s: float
    throttle_volts: float
    regen_volts: float
    hydrobrake_duty: float
    motors_enabled: bool
    ebrake_engaged: bool
    speed_mps: float
    steering_actual_norm: float
    distance_m: float
    brake_light: bool
    reverse_light: bool
    turn_left_light: bool
    turn_right_light: bool
    low_beam: bool
    error_led: bool
    error_flags: int

    @property
    def safe(self) -> bool:
        """STOP with every drive output safe: no throttle, motors disabled, e-brake engaged."""
        return (
            self.mode is ControlMode.STOP
            and self.throttle_volts == 0.0
            and not self.motors_enabled
            and self.ebrake_engaged
        )


def observe(
    world: SimWorld, outputs: ControlOutputs, throttle_channel: int, regen_channel: int
) -> Observation:
    """Read the world now; `outputs` is the controller's latest decision."""
    gpio = world.gpio
    state = world.vehicle.state
    return Observation(
        time_s=world.clock.now(),
        mode=outputs.mode,
        latched=bool(outputs.causes),
        gear=outputs.movement.gear,
        steering_cmd_norm=outputs.movement.steering_norm,
        throttle_cmd_norm=outputs.movement.throttle_norm,
        brake_cmd_norm=outputs.movement.brake_norm,
        steering_pulse_s=world.pwm.steering.pulse_s,
        throttle_volts=world.dac.volts(throttle_channel),
        regen_volts=world.dac.volts(regen_channel),
        hydrobrake_duty=world.pwm.hydrobrake.duty,
        motors_enabled=gpio["motors_enable"].level,
        ebrake_engaged=not gpio["ebrake_release"].level,
        speed_mps=state.speed_mps,
        steering_actual_norm=state.steering_norm,
        distance_m=state.distance_m,
        brake_light=gpio["brake_light"].level,
        reverse_light=gpio["reverse_light"].level,
        turn_left_light=gpio["turn_left_light"].level,
        turn_right_light=gpio["turn_right_light"].level,
        low_beam=gpio["low_beam"].level,
        error_led=gpio["error_led"].level,
        error_flags=outputs.error_flags,
    )


_BOUNDS: dict[str, tuple[str, Callable[[float, float], bool]]] = {
    "throttle_volts_max": ("throttle_volts", operator.le),
    "throttle_volts_min": ("throttle_volts", operator.ge),
    "speed_min_mps": ("speed_mps", operator.ge),
    "speed_max_mps": ("speed_mps", operator.le),
    "hydrobrake_duty_min": ("hydrobrake_duty", operator.ge),
}


def _holds(observation: Observation, key: str, wanted: Any) -> bool:
    if key == "mode":
        return observation.mode.name.lower() == str(wanted).lower()
    if key in _BOUNDS:
        field_name, compare = _BOUNDS[key]
        return compare(getattr(observation, field_name), float(wanted))
    return bool(getattr(observation, key)) is bool(wanted)


def conditions_hold(observation: Observation, conditions: dict[str, Any]) -> bool:
    """True when every condition of an expectation holds in this observation."""
    return all(_holds(observation, key, wanted) for key, wanted in conditions.items())
