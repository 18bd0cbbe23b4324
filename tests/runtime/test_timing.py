"""Supervised timing: budgets on the hardware clock; an overrun is a fault, a slow DAC fails."""

from __future__ import annotations

from bywire.control.dac_health import DAC_TRANSFERS_PER_PASS
from bywire.control.drive import DriveOutputs
from bywire.control.lights import LightOutputs
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.runtime.actuators import ActuatorConfig, Actuators
from bywire.runtime.timing import Budgets, Overruns

DRIVING = DriveOutputs(2.0, 0.0, enable=True, forward=True, reverse=False)


def rig() -> tuple[SimWorld, Actuators]:
    world = SimWorld.create(VirtualClock())
    world.dac.on_stall = world.clock.advance
    return world, Actuators(world.hardware, ActuatorConfig(budgets=Budgets()))


def test_one_overrun_is_counted_and_flagged_but_is_no_fault_a_crawl_is_one_at_once() -> None:
    overruns = Overruns()
    assert not overruns.check("pass", 0.019, 0.020, 1.0)
    assert overruns.check("pass", 0.025, 0.020, 1.0)  # a busy machine's hiccup
    assert overruns.recent.active(1.2)
    assert not overruns.active()
    assert overruns.counts["pass"] == 1
    assert overruns.worst_s["pass"] == 0.025
    assert overruns.check("pass", 0.160, 0.020, 2.0)  # eight budgets in one pass
    assert overruns.active()
    drained = 0
    while overruns.active():
        overruns.on_time()
        drained += 1
    assert drained == 24  # the level is capped at twice the limit: 0.24 s of passes on time


def test_overruns_in_quick_succession_add_up_to_the_fault() -> None:
    overruns = Overruns()
    for _ in range(3):
        overruns.check("pass", 0.021, 0.020, 1.0)
    assert overruns.active()


def test_a_dac_transfer_within_its_budget_is_ordinary() -> None:
    world, actuators = rig()
    world.dac.slow_writes(0.002)
    for tick in range(50):
        actuators.write_drive(DRIVING, tick * 0.01)
    assert not actuators.dac_failing
    assert world.gpio["motors_enable"].level
    assert not actuators.overruns.counts


def test_a_crawling_dac_transfer_is_a_failing_one_and_the_motors_go_off_as_it_returns() -> None:
    world, actuators = rig()
    actuators.write_drive(DRIVING, 0.0)
    world.dac.slow_writes(0.08)
    writes_before = world.dac.writes
    actuators.write_drive(DRIVING, 0.01)
    assert actuators.dac_failing
    assert not world.gpio["motors_enable"].level
    assert world.dac.writes - writes_before == 1  # the pass wrote no more crawling transfers
    assert actuators.overruns.counts["DAC transfer"] == 1


def test_a_port_write_that_hangs_is_timed_by_the_gate() -> None:
    world, actuators = rig()
    line = world.gpio["brake_light"]
    original = line.set

    def hanging(level: bool) -> None:
        world.clock.advance(0.05)
        original(level)

    line.set = hanging  # type: ignore[method-assign]
    actuators.write_lights(LightOutputs(brake=True))
    assert actuators.overruns.counts["lights write"] == 1
    assert actuators.overruns.active(world.clock.now())


def test_a_drive_write_is_the_transfers_the_pass_budget_is_derived_from() -> None:
    # The load check holds DAC_TRANSFERS_PER_PASS transfers within the pass budget: a drive
    # write that made more would let transfers within their budget overrun the pass.
    world, actuators = rig()
    writes_before = world.dac.writes
    actuators.write_drive(DRIVING, 0.0)
    assert world.dac.writes - writes_before == DAC_TRANSFERS_PER_PASS
