"""What is broken in the simulated robot that the checks must allow for: the wheel sensor, the
brakes, and output lines whose writes fail."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Plant:
    """A robot without the sensors (a Linux robot file today) is judged as one whose wheel
    sensor died at power-up: the no-sensor rule must hold it, from standstill on."""

    sensors_fitted: bool = True
    sensor_dead: bool = False  # the wheel-speed sensor reads 0 m/s whatever the robot does…
    died_at_mps: float = 0.0  # …since it died at this speed, unnoticed if slow enough (H4)
    sensor_ever_dead: bool = False  # the wheel sensor died once: its standstill may not count
    hydrobrake_failed: bool = False  # builds no pressure: H4 is off with a dead sensor
    ebrake_failed: bool = False  # the spring brake does not engage (undetectable: row 6)
    servo_stuck: bool = False  # the steering servo stays where it is (H10, with an encoder)
    dead_lines: set[str] = field(default_factory=set)  # outputs whose writes fail (H8)

    def __post_init__(self) -> None:
        self.sensor_dead = not self.sensors_fitted
        self.sensor_ever_dead = self.sensor_dead

    def sensor_dies(self, speed_mps: float) -> None:
        """The wheel-speed sensor reads 0 m/s from now on, the robot rolling at `speed_mps`
        (a sensor that is not fitted has nothing to lose)."""
        if self.sensors_fitted:
            self.sensor_dead, self.died_at_mps = True, abs(speed_mps)
            self.sensor_ever_dead = True

    def sensor_restored(self) -> None:
        self.sensor_dead = not self.sensors_fitted
