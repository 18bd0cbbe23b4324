"""Issue 29, finding 4: the exit path never gives up.

A turn-signal line that dies while the robot drives at full throttle ends the control loop (a
port write that raises is a crash, row 13); writing the safe state must then go on past the dead
line, in order of importance, and name it. Before (dce19d3) the safe-state write stopped at the
lamp: the hydraulic brake stayed at duty 0 and the throttle DAC at ~4.75 V, and a restart failed
the same way. On virtual time the simulator's watchdog hid it, so this runs on the real-time
path `bywire run` takes with a sim backend: a real-time clock and the watchdog's own thread.
"""

from __future__ import annotations

import logging

import pytest

from bywire.config import default_sim_config
from bywire.errors import HardwareError
from bywire.hal.simulated.clock import RealtimeClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario


def _real_time_robot() -> tuple[SimWorld, Runtime]:
    robot = default_sim_config()
    world = SimWorld.from_robot(RealtimeClock(), robot)
    runtime = Runtime(world.hardware, RuntimeConfig.from_robot(robot), watchdog_thread=True)
    return world, runtime


def _assert_safe_but(world: SimWorld, dead: str) -> None:
    gpio = world.gpio
    assert not gpio["motors_enable"].level
    assert not gpio["ebrake_release"].level
    assert world.pwm.hydrobrake.duty == pytest.approx(1.0)
    assert world.dac.volts(0) == 0.0
    assert world.dac.volts(1) == 0.0
    alive = [name for name in gpio if name != dead]
    assert not any(gpio[name].level for name in alive)


def test_a_lamp_line_that_dies_at_full_throttle_ends_with_every_other_output_safe(
    caplog: pytest.LogCaptureFixture,
) -> None:
    world, runtime = _real_time_robot()
    clock, rc = world.clock, world.rc

    def arm() -> None:
        rc.set_mode(ControlMode.STOP)
        rc.set_gear(Gear.FORWARD)

    clock.call_at(0.05, arm)
    clock.call_at(0.15, lambda: rc.set_mode(ControlMode.RC))
    clock.call_at(0.2, lambda: rc.set_pedal(1.0))
    clock.call_at(1.2, lambda: rc.set_hazard(True))  # the turn signals blink: the line is used
    clock.call_at(1.3, world.gpio["turn_left_light"].fail)
    world.start()
    with caplog.at_level(logging.ERROR), pytest.raises(HardwareError, match="turn_left_light"):
        runtime.run(until_s=3.0)
    world.stop()
    assert world.gpio["motors_enable"].level_at(1.25)  # it was driving, throttle above 1 V
    assert world.dac.volts(0) == 0.0
    assert any(v > 1.0 for _, c, v in world.dac.history if c == 0)
    _assert_safe_but(world, "turn_left_light")
    assert "turn_left_light" in caplog.text  # the failure is named


def test_a_restart_with_the_line_still_dead_writes_every_other_safe_level_and_names_it() -> None:
    world, runtime = _real_time_robot()
    for name in ("ebrake_release", "motors_enable"):
        world.gpio[name].set(True)  # as a crashed process left them
    world.gpio["turn_left_light"].fail()
    failures = runtime.actuators.write_safe(world.clock.now(), centre_steering=True)
    assert [line.split(":")[0] for line in failures] == ["turn_left_light"]
    _assert_safe_but(world, "turn_left_light")


@pytest.mark.parametrize("dead", ["motors_enable", "ebrake_release", "hydrobrake", "brake_light"])
def test_whichever_output_dies_the_others_reach_their_safe_level(dead: str) -> None:
    scenario = parse_scenario(
        f"""name = "dead line"
description = "an output dies while driving"
duration_s = 2.0
[[event]]
at_s = 0.3
rc = {{ mode = "stop", gear = "forward", throttle = 0.0 }}
[[event]]
at_s = 0.5
rc = {{ mode = "rc" }}
[[event]]
at_s = 0.6
rc = {{ throttle = 1.0 }}
[[event]]
at_s = 1.2
fault = "line_dead"
line = "{dead}"
""",
        "<dead line>",
    )
    run = SimRun(default_sim_config(), scenario)
    run.run()
    assert run.record.ended_by is not None
    assert dead in run.record.ended_by
    world = run.world
    safe = {
        "motors_enable": not world.gpio["motors_enable"].level,
        "ebrake_release": not world.gpio["ebrake_release"].level,
        "hydrobrake": world.pwm.hydrobrake.duty >= 1.0,
        "dac": world.dac.volts(0) == 0.0,
    }
    assert [name for name, ok in safe.items() if name != dead and not ok] == []
