"""Actuator writes, exactly: every DAC failure and clamp stamped with the write's time, the DAC
code computed against the configured reference, safe writes zeroing both analogue channels."""

from __future__ import annotations

from bywire.control.drive import DriveOutputs
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.world import SimWorld
from bywire.runtime.actuators import ActuatorConfig, Actuators

DRIVING = DriveOutputs(2.0, 0.0, enable=True, forward=True, reverse=False)
BRAKING = DriveOutputs(0.0, 3.0, enable=True, forward=True, reverse=False)


def rig(config: ActuatorConfig | None = None) -> tuple[SimWorld, Actuators]:
    world = SimWorld.create(VirtualClock())
    return world, Actuators(world.hardware, config or ActuatorConfig(dac_failure_limit=3))


def test_the_dac_fault_is_a_plain_false_until_it_trips_and_after_acknowledgement() -> None:
    world, actuators = rig()
    assert actuators.dac_fault is False
    world.dac.fail_writes(count=3)
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_drive(DRIVING, 0.01)
    assert actuators.dac_fault is True
    actuators.write_drive(DRIVING, 0.02)  # the DAC answers again
    assert actuators.acknowledge_dac_fault()
    assert actuators.dac_fault is False


def test_a_failed_throttle_write_is_stamped_with_the_write_time() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=1)  # the throttle write comes first
    actuators.write_drive(DRIVING, 0.25)
    assert actuators.dac_failures.last_at == 0.25


def test_a_failed_safe_write_is_stamped_with_the_write_time_on_either_channel() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=1)  # only the throttle channel fails
    actuators.write_safe(0.25)
    assert actuators.dac_failures.last_at == 0.25
    world.dac.fail_writes()  # both fail: the regen one is the last
    actuators.write_safe(0.5)
    assert actuators.dac_failures.last_at == 0.5


def test_a_clamped_dac_value_is_stamped_with_the_write_time() -> None:
    _, actuators = rig()
    actuators.write_drive(DriveOutputs(6.0, 0.0, True, True, False), 0.25)  # above Vref = 5 V
    assert actuators.dac_clamps.last_at == 0.25


def test_dac_codes_are_computed_against_the_configured_reference() -> None:
    world, actuators = rig(ActuatorConfig(dac_vref_volts=2.5))
    actuators.write_drive(DriveOutputs(1.25, 0.0, True, True, False), 0.0)
    assert world.dac.code(0) == 512  # half of the 2.5 V reference, not a quarter of 5 V


def test_safe_writes_zero_both_analogue_channels() -> None:
    world, actuators = rig()
    actuators.write_drive(BRAKING, 0.0)
    actuators.write_drive(DRIVING, 0.01)
    assert world.dac.volts(0) > 0.0
    actuators.write_drive(BRAKING, 0.02)
    assert world.dac.volts(1) > 0.0
    actuators.write_safe(0.03)
    assert world.dac.volts(0) == 0.0
    assert world.dac.volts(1) == 0.0
