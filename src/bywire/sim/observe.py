"""What a scenario can see of the simulated robot at one instant (its expectations are judged on
it: `bywire.sim.conditions`).

Observations read the simulated hardware (DAC volts, GPIO levels, PWM duty, the vehicle), not the
controller's intentions, so "safe within 110 ms" means the outputs really were safe.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.controller import ControlOutputs
from bywire.control.lights import LIGHT_LINES, LightOutputs
from bywire.control.values import slot_init
from bywire.hal.simulated.world import SimWorld
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
    steering_changed_at_s: float  # when the steering pulse last changed (0: never set)
    throttle_volts: float
    regen_volts: float
    hydrobrake_duty: float
    motors_enabled: bool
    ebrake_engaged: bool
    speed_mps: float
    steering_actual_norm: float
    distance_m: float
    lights: LightOutputs  # as the lines show them, each read from its own (`LIGHT_LINES`)
    error_flags: int
    bridge_unshown_drop: bool | None = None  # the bridge dropped a live set-point, unwarned
    bridge_throttle_norm: float | None = None  # the throttle the bridge asked for, last period

    def __init__(  # noqa: PLR0917
        self,
        time_s: float,
        mode: ControlMode,
        latched: bool,
        gear: Gear,
        steering_cmd_norm: float,
        throttle_cmd_norm: float,
        brake_cmd_norm: float,
        steering_pulse_s: float,
        steering_changed_at_s: float,
        throttle_volts: float,
        regen_volts: float,
        hydrobrake_duty: float,
        motors_enabled: bool,
        ebrake_engaged: bool,
        speed_mps: float,
        steering_actual_norm: float,
        distance_m: float,
        lights: LightOutputs,
        error_flags: int,
        bridge_unshown_drop: bool | None = None,
        bridge_throttle_norm: float | None = None,
    ) -> None:
        object.__setattr__(self, "time_s", time_s)
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "latched", latched)
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "steering_cmd_norm", steering_cmd_norm)
        object.__setattr__(self, "throttle_cmd_norm", throttle_cmd_norm)
        object.__setattr__(self, "brake_cmd_norm", brake_cmd_norm)
        object.__setattr__(self, "steering_pulse_s", steering_pulse_s)
        object.__setattr__(self, "steering_changed_at_s", steering_changed_at_s)
        object.__setattr__(self, "throttle_volts", throttle_volts)
        object.__setattr__(self, "regen_volts", regen_volts)
        object.__setattr__(self, "hydrobrake_duty", hydrobrake_duty)
        object.__setattr__(self, "motors_enabled", motors_enabled)
        object.__setattr__(self, "ebrake_engaged", ebrake_engaged)
        object.__setattr__(self, "speed_mps", speed_mps)
        object.__setattr__(self, "steering_actual_norm", steering_actual_norm)
        object.__setattr__(self, "distance_m", distance_m)
        object.__setattr__(self, "lights", lights)
        object.__setattr__(self, "error_flags", error_flags)
        object.__setattr__(self, "bridge_unshown_drop", bridge_unshown_drop)
        object.__setattr__(self, "bridge_throttle_norm", bridge_throttle_norm)

    @property
    def drive_safe(self) -> bool:
        """The drive stops the robot: throttle at 0 V, and the motors disabled or (a controlled
        stop, category 1) braking with the regenerative brake."""
        return self.throttle_volts == 0.0 and (not self.motors_enabled or self.regen_volts > 0.0)

    @property
    def safe(self) -> bool:
        """STOP with every drive output safe: the drive stopping (`drive_safe`), the e-brake
        engaged."""
        return self.mode is ControlMode.STOP and self.drive_safe and self.ebrake_engaged


slot_init(Observation)


def observe(world: SimWorld, outputs: ControlOutputs) -> Observation:
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
        steering_changed_at_s=_changed_at_s(world.pwm.steering.history),
        throttle_volts=world.throttle_volts,
        regen_volts=world.regen_volts,
        hydrobrake_duty=world.pwm.hydrobrake.duty,
        motors_enabled=gpio["motors_enable"].level,
        ebrake_engaged=not gpio["ebrake_release"].level,
        speed_mps=state.speed_mps,
        steering_actual_norm=state.steering_norm,
        distance_m=state.distance_m,
        lights=LightOutputs(**{name: gpio[light.line].level for name, light in LIGHT_LINES}),
        error_flags=outputs.error_flags,
    )


def _changed_at_s(history: list[tuple[float, float]]) -> float:
    return history[-1][0] if history else 0.0
