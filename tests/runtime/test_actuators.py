"""Actuator writes: DAC failures escalate at exactly the limit; safe writes reach every output."""

from __future__ import annotations

import pytest

from bywire.control.drive import DriveOutputs
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.world import SimWorld
from bywire.runtime.actuators import ActuatorConfig, Actuators

DRIVING = DriveOutputs(2.0, 0.0, enable=True, forward=True, reverse=False)


def rig() -> tuple[SimWorld, Actuators]:
    world = SimWorld.create(VirtualClock())
    return world, Actuators(world.hardware, ActuatorConfig(dac_failure_limit=3))


def test_two_failed_writes_are_flagged_but_keep_the_motors_enabled() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes(count=2)
    actuators.write_drive(DRIVING, 0.01)  # throttle and regen writes both fail
    assert actuators.consecutive_dac_failures == 2
    assert not actuators.dac_fault
    assert actuators.dac_failures.active(0.01)
    assert world.gpio["motors_enable"].level


def test_the_third_failed_write_disables_the_motors_at_once() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes(count=3)
    actuators.write_drive(DRIVING, 0.01)
    actuators.write_drive(DRIVING, 0.02)  # the third failure, on the throttle write
    assert actuators.dac_fault
    assert not world.gpio["motors_enable"].level


def test_the_fault_holds_through_good_writes_until_acknowledged() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=3)
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_drive(DRIVING, 0.01)  # third failure, then the regen write succeeds
    actuators.write_drive(DRIVING, 0.02)
    assert actuators.consecutive_dac_failures == 0
    assert actuators.dac_fault
    assert not world.gpio["motors_enable"].level
    assert actuators.acknowledge_dac_fault()
    actuators.write_drive(DRIVING, 0.03)
    assert world.gpio["motors_enable"].level


def test_acknowledging_a_dac_that_still_fails_changes_nothing() -> None:
    world, actuators = rig()
    world.dac.fail_writes()
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_drive(DRIVING, 0.01)
    assert not actuators.acknowledge_dac_fault()
    assert actuators.dac_fault


def test_a_good_write_clears_the_run_of_failures() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=2)
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_drive(DRIVING, 0.01)
    assert actuators.consecutive_dac_failures == 0
    assert not actuators.dac_fault


def test_safe_writes_reach_every_output_even_when_the_dac_fails() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_brakes(0.0, ebrake_engaged=False)
    world.dac.fail_writes()
    actuators.write_safe(0.1)
    assert not any(line.level for line in world.gpio.values())
    assert world.pwm.hydrobrake.duty == pytest.approx(1.0)
    assert world.pwm.steering.pulse_s == pytest.approx(0.0015)
