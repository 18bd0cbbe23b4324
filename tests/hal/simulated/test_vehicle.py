"""The vehicle on the clock: reads the real actuator ports every step, reports wheel speeds."""

from __future__ import annotations

import pytest

from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.dac import SimDac6574
from bywire.hal.simulated.gpio_pwm import SimDigitalOut, SimPwmChannel
from bywire.hal.simulated.vehicle import (
    SimPressureSensor,
    SimSteeringEncoder,
    SimVehicle,
    SimWheelSpeedSensor,
    VehicleWiring,
)
from bywire.protocol import dac6574


def wired_vehicle(
    throttle_channel: int = 0, regen_channel: int = 1
) -> tuple[VirtualClock, VehicleWiring, SimVehicle]:
    clock = VirtualClock()
    wiring = VehicleWiring(
        dac=SimDac6574(clock),
        motors_enable=SimDigitalOut(clock),
        motors_forward=SimDigitalOut(clock),
        motors_reverse=SimDigitalOut(clock),
        ebrake_release=SimDigitalOut(clock),
        steering_pwm=SimPwmChannel(clock, 0.02),
        hydrobrake_pwm=SimPwmChannel(clock, 0.001),
        throttle_channel=throttle_channel,
        regen_channel=regen_channel,
    )
    vehicle = SimVehicle(clock, wiring)
    vehicle.start()
    return clock, wiring, vehicle


def drive_forward(wiring: VehicleWiring, throttle_code: int = 1023) -> None:
    wiring.dac.write(dac6574.encode_write(wiring.throttle_channel, throttle_code))
    wiring.motors_enable.set(True)
    wiring.motors_forward.set(True)
    wiring.ebrake_release.set(True)


def test_throttle_on_its_dac_channel_drives_the_vehicle() -> None:
    clock, wiring, vehicle = wired_vehicle(throttle_channel=2, regen_channel=3)
    drive_forward(wiring)
    clock.advance(2.0)
    assert vehicle.state.speed_mps > 1.0
    assert vehicle.inputs.throttle_volts == pytest.approx(5.0 * 1023 / 1024)
    assert len(vehicle.history) == 400
    assert vehicle.history[-1][0] == pytest.approx(2.0)
    assert vehicle.history[0][0] == pytest.approx(0.005)


def test_a_safe_state_robot_stays_put() -> None:
    clock, wiring, vehicle = wired_vehicle()
    wiring.dac.write(dac6574.encode_write(0, 1023))  # throttle alone, every line low
    clock.advance(2.0)
    assert vehicle.state.speed_mps == 0.0
    assert vehicle.state.distance_m == 0.0


def test_regen_volts_and_hydraulic_duty_brake_to_standstill() -> None:
    clock, wiring, vehicle = wired_vehicle()
    drive_forward(wiring)
    clock.advance(3.0)
    wiring.dac.write(dac6574.encode_write(0, 0))
    wiring.dac.write(dac6574.encode_write(1, 1023))
    wiring.hydrobrake_pwm.set_pulse(0.0005)
    clock.advance(3.0)
    assert vehicle.state.speed_mps == 0.0
    assert vehicle.inputs.hydraulic_duty == pytest.approx(0.5)
    assert min(state.speed_mps for _, state in vehicle.history) == 0.0


def test_servo_pulse_steers_the_vehicle_at_the_servo_rate() -> None:
    clock, wiring, vehicle = wired_vehicle()
    wiring.steering_pwm.set_pulse(0.002)
    clock.advance(0.4)
    assert vehicle.state.steering_norm == pytest.approx(0.6)


def test_wheel_speed_sensor_reads_the_vehicle_and_can_fail() -> None:
    clock, wiring, vehicle = wired_vehicle()
    sensor = SimWheelSpeedSensor(vehicle)
    assert sensor.read() == (0.0, 0.0)
    drive_forward(wiring)
    clock.advance(1.0)
    reading = sensor.read()
    assert reading is not None
    assert reading[0] == reading[1] == vehicle.state.speed_mps > 0.0
    sensor.fail()
    assert sensor.read() is None
    sensor.restore()
    assert sensor.read() == vehicle.wheel_speeds()


def test_stop_freezes_the_vehicle() -> None:
    clock, wiring, vehicle = wired_vehicle()
    drive_forward(wiring)
    clock.advance(1.0)
    vehicle.stop()
    frozen = vehicle.state
    clock.advance(1.0)
    assert vehicle.state == frozen


def test_a_failed_hydraulic_brake_neither_brakes_nor_builds_pressure() -> None:
    clock, wiring, vehicle = wired_vehicle()
    sensor = SimPressureSensor(vehicle)
    drive_forward(wiring)
    clock.advance(2.0)
    wiring.dac.write(dac6574.encode_write(0, 0))
    wiring.motors_enable.set(False)
    vehicle.faults.hydrobrake_failed = True
    wiring.hydrobrake_pwm.set_pulse(0.001)  # full duty commanded
    clock.advance(0.1)
    assert sensor.read() == 0.0
    coasting_mps = vehicle.state.speed_mps
    assert coasting_mps > 0.5
    vehicle.faults.hydrobrake_failed = False
    clock.advance(0.1)
    assert sensor.read() == pytest.approx(10.0)
    assert vehicle.state.speed_mps < coasting_mps - 0.3


def test_a_failed_ebrake_does_not_stop_the_vehicle() -> None:
    clock, wiring, vehicle = wired_vehicle()
    drive_forward(wiring)
    clock.advance(2.0)
    wiring.motors_enable.set(False)
    vehicle.faults.ebrake_failed = True
    wiring.ebrake_release.set(False)  # engage: but it is broken
    clock.advance(0.2)
    assert vehicle.state.speed_mps > 1.0


def test_a_stuck_servo_stays_and_the_encoder_tells() -> None:
    clock, wiring, vehicle = wired_vehicle()
    encoder = SimSteeringEncoder(vehicle)
    wiring.steering_pwm.set_pulse(0.002)
    clock.advance(1.0)
    assert encoder.read() == pytest.approx(1.0)
    vehicle.faults.servo_stuck = True
    wiring.steering_pwm.set_pulse(0.001)
    clock.advance(1.0)
    assert encoder.read() == pytest.approx(1.0)
    encoder.failed = True
    assert encoder.read() is None
