"""A fitted sensor that goes silent is a fault for the decision, never an absent sensor."""

from __future__ import annotations

import math
from dataclasses import replace

from bywire.config import default_sim_config
from bywire.errors import HardwareError
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode
from bywire.runtime.sensors import SensorReadings, read_sensors
from bywire.sim.verify.campaign import Campaign, Step


def test_an_absent_sensor_gives_the_decision_nothing_to_check() -> None:
    readings = SensorReadings()
    assert readings.checked_speed_mps is None
    assert readings.checked_pressure_bar is None
    assert readings.checked_steering_norm is None


def test_a_fitted_sensor_without_a_reading_gives_the_decision_an_invalid_one() -> None:
    readings = SensorReadings(wheels_fitted=True, pressure_fitted=True, encoder_fitted=True)
    assert readings.speed_mps is None  # what reports and telemetry show: no reading
    for checked in (
        readings.checked_speed_mps,
        readings.checked_pressure_bar,
        readings.checked_steering_norm,
    ):
        assert checked is not None
        assert math.isnan(checked)


def test_a_fitted_sensor_with_a_reading_passes_it_on() -> None:
    readings = SensorReadings((1.0, 3.0), 4.5, -0.25, True, True, True)
    assert (readings.checked_speed_mps, readings.checked_pressure_bar) == (2.0, 4.5)
    assert readings.checked_steering_norm == -0.25


def test_the_simulated_robot_reads_as_fitted_and_a_failed_encoder_as_silent() -> None:
    world = SimWorld.from_robot(VirtualClock(), default_sim_config())
    world.steering_encoder.failed = True
    readings = read_sensors(world.hardware)
    assert readings.encoder_fitted
    assert readings.steering_measured_norm is None
    checked = readings.checked_steering_norm
    assert checked is not None
    assert math.isnan(checked)


def test_an_encoder_that_dies_quietly_while_driving_stops_the_robot() -> None:
    # Driving in CAN, the steering encoder stops answering: its monitor must not switch itself
    # off. Judged on the hardware: motors disabled and the e-brake engaged.
    steps = [
        Step(0.2, "arm", ControlMode.CAN),
        Step(0.15, "can_throttle", 0.3),
        Step(0.5, "encoder", False),
        Step(0.3, "can_steer", 0.0),
    ]
    result = Campaign().run(steps)
    world = result.oracle.world
    assert not world.gpio["motors_enable"].level
    assert not world.gpio["ebrake_release"].level
    assert result.transitions >= {"CAN->STOP: STEERING_ENCODER latched"}


class _DeadLine:
    """An E-stop line whose reads fail (its chip gone)."""

    def get(self) -> bool:
        raise HardwareError("GPIO estop.line: cannot read (No such device)")


def test_an_estop_line_that_cannot_be_read_reads_as_pressed() -> None:
    world = SimWorld.from_robot(VirtualClock(), default_sim_config())
    assert read_sensors(world.hardware).estop_line_high is True  # released
    world.estop.press()
    assert read_sensors(world.hardware).estop_line_high is False
    dead = replace(world.hardware, estop_line=_DeadLine())
    assert read_sensors(dead).estop_line_high is False  # low: pressed, never "no E-stop"
    assert read_sensors(replace(world.hardware, estop_line=None)).estop_line_high is None
