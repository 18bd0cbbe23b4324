"""Actuator writes: how DAC failures escalate, the enable line, the watchdog's gate, safe writes."""

from __future__ import annotations

import math

import pytest

from bywire.config import DacOutput
from bywire.control.dac_health import DAC_LEAK
from bywire.control.drive import DriveOutputs
from bywire.control.lights import LIGHT_LINES, LightOutputs
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.runtime.actuators import ActuatorConfig, Actuators
from bywire.task_table import TaskSpec

DRIVING = DriveOutputs(2.0, 0.0, enable=True, forward=True, reverse=False)
FASTER = DriveOutputs(3.0, 0.0, enable=True, forward=True, reverse=False)
BRAKING = DriveOutputs(0.0, 3.0, enable=True, forward=True, reverse=False)


def rig(config: ActuatorConfig | None = None) -> tuple[SimWorld, Actuators]:
    world = SimWorld.create(VirtualClock())
    return world, Actuators(world.hardware, config or ActuatorConfig(dac_failure_limit=3))


def enabled(world: SimWorld) -> bool:
    return world.gpio["motors_enable"].level


# --- escalation -------------------------------------------------------------------------------


def test_two_failed_writes_that_raise_a_voltage_are_flagged_but_keep_the_motors_enabled() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes(count=2)
    actuators.write_drive(FASTER, 0.01)  # throttle up and regen (unchanged) both fail
    assert actuators.dac_failure_level == 2.0
    assert not actuators.dac_failing
    assert actuators.dac_failures.last_at == 0.01
    assert enabled(world)


def test_the_third_failure_in_a_row_disables_the_motors_at_once() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes(count=3)
    actuators.write_drive(DRIVING, 0.01)
    assert enabled(world)
    actuators.write_drive(DRIVING, 0.02)  # the third failure, on the throttle write
    assert actuators.dac_failing
    assert not enabled(world)


def test_every_other_write_failing_escalates_where_a_run_of_failures_never_would() -> None:
    world, actuators = rig()
    outcomes = []
    for index in range(8):
        world.dac.fail_writes(count=1)  # the throttle write fails, the regen write succeeds
        actuators.write_drive(DRIVING, index * 0.01)
        outcomes.append(actuators.dac_failing)
    assert outcomes[-1]
    # +1 then -0.25 per driving period: the level reaches 3 on the fourth failure
    assert outcomes.index(True) == 3
    assert not enabled(world)


def test_the_escalation_holds_until_the_count_has_drained() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=3)
    for index in range(2):
        actuators.write_drive(DRIVING, index * 0.01)
    assert actuators.dac_failing
    periods_to_drain = math.ceil(actuators.dac_failure_level / DAC_LEAK / 2)  # 2 writes a period
    for index in range(periods_to_drain - 1):
        actuators.write_drive(DRIVING, 0.1 + index * 0.01)
    assert actuators.dac_failing  # one period short of drained
    assert not enabled(world)
    actuators.write_drive(DRIVING, 1.0)
    assert not actuators.dac_failing
    assert enabled(world)


def test_a_failed_write_that_should_lower_a_voltage_disables_the_motors_at_once() -> None:
    world, actuators = rig()
    actuators.write_drive(FASTER, 0.0)
    world.dac.fail_writes(count=1)
    actuators.write_drive(DRIVING, 0.01)  # 3 V → 2 V refused: the DAC may still drive 3 V
    assert world.dac.volts(0) == pytest.approx(3.0, abs=0.01)
    assert actuators.dac_failure_level == 1.0 - DAC_LEAK  # the regen write went through
    assert actuators.dac_failing
    assert not enabled(world)
    actuators.write_drive(DRIVING, 0.02)  # written: the channel holds what it was told
    assert not actuators.dac_failing
    assert enabled(world)


def test_the_dac_failure_level_is_bounded_so_recovery_never_takes_forever() -> None:
    world, actuators = rig()
    world.dac.fail_writes()
    for index in range(100):
        actuators.write_drive(DRIVING, index * 0.01)
    assert actuators.dac_failure_level == 6.0


# --- stamps and codes -------------------------------------------------------------------------


def test_a_failed_throttle_write_is_stamped_with_the_write_time() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=1)  # the throttle write comes first
    actuators.write_drive(DRIVING, 0.25)
    assert actuators.dac_failures.last_at == 0.25


def test_a_failed_safe_write_is_stamped_with_the_write_time_on_either_channel() -> None:
    world, actuators = rig()
    world.dac.fail_writes(count=1)  # only the throttle channel fails
    actuators.write_safe(0.25, centre_steering=True)
    assert actuators.dac_failures.last_at == 0.25
    world.dac.fail_writes()  # both fail: the regen one is the last
    actuators.write_safe(0.5, centre_steering=True)
    assert actuators.dac_failures.last_at == 0.5


def test_a_clamped_dac_value_is_stamped_with_the_write_time() -> None:
    _, actuators = rig()
    actuators.write_drive(DriveOutputs(6.0, 0.0, True, True, False), 0.25)  # above Vref = 5 V
    assert actuators.dac_clamps.last_at == 0.25


def test_dac_codes_are_computed_against_the_configured_reference() -> None:
    world, actuators = rig(ActuatorConfig(dac=DacOutput(vref_volts=2.5)))
    actuators.write_drive(DriveOutputs(1.25, 0.0, True, True, False), 0.0)
    assert world.dac.code(0) == 512  # half of the 2.5 V reference, not a quarter of 5 V


# --- safe writes and the watchdog's gate ---------------------------------------------------------


def test_safe_writes_reach_every_output_even_when_the_dac_fails() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_brakes(0.0, ebrake_engaged=False)
    world.dac.fail_writes()
    actuators.write_safe(0.1, centre_steering=True)
    assert not any(line.level for line in world.gpio.values())
    assert world.pwm.hydrobrake.duty == pytest.approx(1.0)
    assert world.pwm.steering.pulse_s == pytest.approx(0.0015)


def test_safe_writes_zero_both_analogue_channels() -> None:
    world, actuators = rig()
    actuators.write_drive(BRAKING, 0.0)
    actuators.write_drive(DRIVING, 0.01)
    assert world.dac.volts(0) > 0.0
    actuators.write_drive(BRAKING, 0.02)
    assert world.dac.volts(1) > 0.0
    actuators.write_safe(0.03, centre_steering=False)
    assert (world.dac.volts(0), world.dac.volts(1)) == (0.0, 0.0)


def test_safe_writes_hold_the_steering_unless_asked_to_centre_it() -> None:
    world, actuators = rig()
    actuators.write_steering(0.0018)
    actuators.write_safe(0.1, centre_steering=False)
    assert world.pwm.steering.pulse_s == pytest.approx(0.0018)


def test_a_watchdog_trip_makes_every_output_safe_holds_the_steering_and_lights_the_led() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    actuators.write_brakes(0.0, ebrake_engaged=False)
    actuators.write_steering(0.0018)
    actuators.watchdog_trip()
    assert not enabled(world)
    assert not world.gpio["ebrake_release"].level
    assert world.dac.volts(0) == 0.0
    assert world.pwm.hydrobrake.duty == pytest.approx(1.0)
    assert world.pwm.steering.pulse_s == pytest.approx(0.0018)
    assert world.gpio["error_led"].level


def test_after_a_trip_no_loop_write_reaches_a_port_until_it_is_acknowledged() -> None:
    world, actuators = rig()
    actuators.watchdog_trip()
    levels = {name: line.level for name, line in world.gpio.items()}
    actuators.write_drive(DRIVING, 0.1)
    actuators.write_brakes(0.0, ebrake_engaged=False)
    actuators.write_steering(0.0018)
    actuators.write_lights(LightOutputs(brake=True))
    assert {name: line.level for name, line in world.gpio.items()} == levels  # only safe ones
    assert world.dac.volts(0) == 0.0
    assert world.pwm.steering.pulse_s == 0.0  # never written: held
    actuators.gate.reset()
    actuators.write_drive(DRIVING, 0.2)
    assert enabled(world)
    assert world.dac.volts(0) == pytest.approx(2.0, abs=0.01)


def test_a_safe_level_that_failed_at_the_trip_lands_once_the_port_works_again() -> None:
    # Found by `bywire verify`: the DAC NAKed every write, held 1.5 V, then the watchdog tripped
    # (its 0 V failed too) and the DAC recovered; nothing wrote 0 V again until acknowledged.
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes()
    actuators.watchdog_trip()
    assert world.dac.volts(0) == pytest.approx(2.0, abs=0.01)  # its 0 V could not land
    world.dac.stop_failing()
    actuators.write_drive(DRIVING, 0.1)  # the loop's next pass, still tripped
    assert world.dac.volts(0) == 0.0
    assert not enabled(world)


def test_a_write_in_flight_when_the_watchdog_trips_is_undone_before_the_port_is_let_go() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    tripped_inside: list[float] = []

    def trip_while_writing(_stall_s: float) -> None:
        actuators.watchdog_trip()  # the watchdog's thread, while the loop is inside the port
        tripped_inside.append(world.dac.volts(0))

    world.dac.on_stall = trip_while_writing
    world.dac.stall_next_write(0.3)
    actuators.write_drive(FASTER, 0.01)
    assert tripped_inside == [pytest.approx(2.0, abs=0.01)]  # the write had not landed yet
    assert world.dac.volts(0) == 0.0  # it landed, and was undone under the same lock
    assert [volts for _, channel, volts in world.dac.history if channel == 0][-2:] == [
        pytest.approx(3.0, abs=0.01),
        0.0,
    ]
    assert not enabled(world)


def test_each_light_output_drives_its_own_line_and_only_that() -> None:
    for name, light in LIGHT_LINES:
        world, actuators = rig()
        actuators.write_lights(LightOutputs(**{name: True}))
        lit = [line for line, out in world.gpio.items() if out.level]
        assert lit == [light.line], name


def test_a_watchdog_trip_writes_each_light_lines_own_safe_level_and_holds_the_others() -> None:
    world, actuators = rig()
    lit = LightOutputs(**{name: True for name, _ in LIGHT_LINES})
    actuators.write_lights(lit)
    actuators.watchdog_trip()
    levels = {light.line: world.gpio[light.line].level for _, light in LIGHT_LINES}
    assert levels == {
        light.line: True if light.tripped is None else light.tripped for _, light in LIGHT_LINES
    }
    assert world.gpio["error_led"].level


# --- line tasks (a schedule row's `lines`) ----------------------------------------------------

BEEPER = TaskSpec("beeper", 10.0, 0.002, lambda *_: None, lines=("low_beam", "reverse_light"))


def test_a_line_task_writes_its_lines_through_the_gate_and_a_trip_drives_them_low() -> None:
    world, actuators = rig(ActuatorConfig(line_tasks=(BEEPER,)))
    actuators.write_lines("beeper", {"low_beam": True, "reverse_light": True})
    assert world.gpio["low_beam"].level
    actuators.watchdog_trip()
    assert not world.gpio["low_beam"].level
    assert not world.gpio["reverse_light"].level
    actuators.write_lines("beeper", {"low_beam": True})
    assert not world.gpio["low_beam"].level  # refused by the gate until acknowledged
    actuators.gate.reset()
    actuators.write_lines("beeper", {"low_beam": True})
    assert world.gpio["low_beam"].level


@pytest.mark.parametrize("line_tasks", [(), (BEEPER,)])
def test_the_safe_state_writes_a_line_tasks_lines_low_too(line_tasks: tuple[TaskSpec]) -> None:
    """The lights write these lines low as well: the row's own writes are the second try."""
    world, actuators = rig(ActuatorConfig(line_tasks=line_tasks))
    world.gpio["reverse_light"].fail()
    failures = actuators.write_safe(0.0, centre_steering=False)
    tries = [failure for failure in failures if failure.startswith("reverse_light:")]
    assert len(tries) == 1 + len(line_tasks)


def test_a_failed_dac_write_s_cause_is_logged_once_until_the_dac_is_healthy_again(
    caplog: pytest.LogCaptureFixture,
) -> None:
    world, actuators = rig(ActuatorConfig(dac_failure_limit=100))
    actuators.write_drive(DRIVING, 0.0)
    world.dac.fail_writes(count=6)
    for tick in range(1, 4):
        actuators.write_drive(FASTER if tick % 2 else DRIVING, tick * 0.01)
    causes = [r.getMessage() for r in caplog.records if "DAC write failed" in r.getMessage()]
    assert causes == ["DAC write failed: DAC6574: no acknowledge (simulated bus fault)"]
    for tick in range(4, 400):  # acknowledged until the leaky count has drained
        actuators.write_drive(FASTER if tick % 2 else DRIVING, tick * 0.01)
    assert actuators.dac_failure_level == 0.0
    world.dac.fail_writes(count=1)
    actuators.write_drive(DRIVING, 5.0)
    causes = [r.getMessage() for r in caplog.records if "DAC write failed" in r.getMessage()]
    assert len(causes) == 2  # a new failure after health is news again
