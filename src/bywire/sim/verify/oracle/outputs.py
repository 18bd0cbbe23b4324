"""What the simulated hardware shows, read once after a pass of the loop: the only thing the
checks look at besides what was done to the robot."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.values import slot_init
from bywire.hal.simulated.vehicle_model import servo_target_norm
from bywire.hal.simulated.world import SimWorld


@dataclass(frozen=True, slots=True)
class Outputs:
    """The output levels and the vehicle's true speed at one instant. An `@value` (its fields
    stored through their slots): one is read after every pass, ~350 a simulated second."""

    enable: bool  # the motors' enable line
    released: bool  # the e-brake release line (high: the spring brake is released)
    throttle_volts: float
    regen_volts: float
    hydrobrake_duty: float
    steering_pulse_s: float
    speed_mps: float  # signed: forward above zero
    forward: bool  # the direction lines
    reverse: bool
    steering_norm: float = 0.0  # where the servo really is, -1..1 (the vehicle's own frame)
    asked_steering_norm: float = 0.0  # where the steering pulse asks it to be (the same frame)

    def __init__(  # noqa: PLR0917
        self,
        enable: bool,
        released: bool,
        throttle_volts: float,
        regen_volts: float,
        hydrobrake_duty: float,
        steering_pulse_s: float,
        speed_mps: float,
        forward: bool,
        reverse: bool,
        steering_norm: float = 0.0,
        asked_steering_norm: float = 0.0,
    ) -> None:
        object.__setattr__(self, "enable", enable)
        object.__setattr__(self, "released", released)
        object.__setattr__(self, "throttle_volts", throttle_volts)
        object.__setattr__(self, "regen_volts", regen_volts)
        object.__setattr__(self, "hydrobrake_duty", hydrobrake_duty)
        object.__setattr__(self, "steering_pulse_s", steering_pulse_s)
        object.__setattr__(self, "speed_mps", speed_mps)
        object.__setattr__(self, "forward", forward)
        object.__setattr__(self, "reverse", reverse)
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "asked_steering_norm", asked_steering_norm)

    @classmethod
    def read(cls, world: SimWorld) -> Outputs:
        gpio, pwm = world.gpio, world.pwm
        vehicle = world.vehicle.model
        steering = world.vehicle.state.steering_norm
        return cls(
            enable=gpio["motors_enable"].level,
            released=gpio["ebrake_release"].level,
            throttle_volts=world.throttle_volts,
            regen_volts=world.regen_volts,
            hydrobrake_duty=pwm.hydrobrake.duty,
            steering_pulse_s=pwm.steering.pulse_s,
            speed_mps=world.vehicle.state.speed_mps,
            forward=gpio["motors_forward"].level,
            reverse=gpio["motors_reverse"].level,
            steering_norm=steering,
            asked_steering_norm=servo_target_norm(pwm.steering.pulse_s, steering, vehicle.config),
        )


slot_init(Outputs)
