"""The ROS 2 bridge as the simulated computer (`sim/bridge_computer.py`), as scenarios say it:
`computer = "bridge"`, its parameters checked as the node checks them, planner and service
events; files without it read as before; and what the run does with it, on the hardware."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.config import default_sim_config
from bywire.config.speed_limit import LimitsSection
from bywire.errors import ConfigError
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario, scenario_toml

BRIDGE_RUN = """
name = "bridge"
computer = "bridge"
duration_s = 4.0
[[event]]
at_s = 0.1
rc = { mode = "stop" }
[[event]]
at_s = 0.2
rc = { mode = "can" }
[[event]]
at_s = 0.3
bridge_service = { enable = true }
[[event]]
at_s = 0.6
planner = { speed_mps = 1.0, curvature_per_m = 0.5, rate_hz = 20.0, publishing = true }
[[event]]
at_s = %s
label = "silent"
fault = "can_silence"
[[expect]]
after = "silent"
within_s = 0.5
ebrake_engaged = true
[bridge]
stop_ramp_s = 0.3
feedforward_speeds_mps = [0.0, 2.9]
feedforward_throttles = [0.125, 0.811]
"""


def test_a_bridge_scenario_reads_back_as_written() -> None:
    scenario = parse_scenario(BRIDGE_RUN % 3.0, "bridge.toml")
    assert scenario.computer == "bridge"
    assert dict(scenario.bridge)["stop_ramp_s"] == 0.3
    assert dict(scenario.bridge)["feedforward_speeds_mps"] == (0.0, 2.9)
    assert parse_scenario(scenario_toml(scenario), "again.toml") == scenario


def test_a_scenario_without_the_bridge_reads_and_writes_as_before() -> None:
    text = "[[event]]\nat_s = 0.5\nhlc = { throttle = 0.2 }\n"
    scenario = parse_scenario(text, "old.toml")
    assert (scenario.computer, scenario.bridge) == ("hlc", ())
    written = scenario_toml(scenario)
    assert "computer" not in written
    assert "bridge" not in written


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('computer = "ros"', 'computer: got "ros"; allowed: bridge, hlc'),
        ('computer = "bridge"\n[bridge]\nstop_ramp_s = 0.2', "stop_ramp_s = 0.2: out of range"),
        ('computer = "bridge"\n[bridge]\nhold = 0.5', "unknown parameter hold"),
        ("[bridge]\nstop_ramp_s = 0.4", 'parameters of the bridge need computer = "bridge"'),
        (
            "[[event]]\nat_s = 1.0\nplanner = { speed_mps = 0.5 }",
            'event[0].planner: needs computer = "bridge"',
        ),
        (
            'computer = "bridge"\n[[event]]\nat_s = 1.0\nplanner = { rate_hz = 0.0 }',
            "rate_hz: got 0.0; allowed: a number in 1..100 Hz",
        ),
    ],
)
def test_bad_bridge_scenarios_are_refused_naming_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError) as error:
        parse_scenario(text, "bad.toml")
    assert message in str(error.value)


def test_the_bridge_drives_the_robot_and_its_silence_is_the_controllers_can_timeout() -> None:
    """The bridge enabled by ~/enable drives (the motors enabled, the robot moving, turning left
    for a positive curvature); once its link falls silent the spring brake engages."""
    run = SimRun(default_sim_config(), parse_scenario(BRIDGE_RUN % 3.0, "bridge.toml"))
    speeds: list[tuple[float, float, float]] = []
    run.runtime.on_cycle.append(
        lambda now: speeds.append(
            (now, run.world.vehicle.state.speed_mps, run.world.vehicle.state.steering_norm)
        )
    )
    record = run.run()
    before = [(s, steer) for t, s, steer in speeds if 2.5 < t < 3.0]
    assert min(s for s, _ in before) > 0.8
    assert max(steer for _, steer in before) < -0.1  # left: negative steering
    assert all(verdict.passed for verdict in record.verdicts), record.verdicts
    assert run.bridge is not None
    assert not run.bridge.sending


def test_a_scenario_bounds_the_throttle_the_bridge_asks_for() -> None:
    """`bridge_throttle_max_norm` reads the throttle of the bridge's latest period: while it
    drives at 1 m/s it asks for some (0 is exceeded, 1 is not); once the planner falls silent,
    none (B1's finding is written with it)."""
    text = (BRIDGE_RUN % 3.0).replace(
        "[bridge]",
        """[[expect]]
at_s = 2.5
bridge_throttle_max_norm = 0.0
[[expect]]
at_s = 2.5
bridge_throttle_max_norm = 1.0
[[event]]
at_s = 2.6
planner = { publishing = false }
[[expect]]
at_s = 2.9
bridge_throttle_max_norm = 0.0
[bridge]""",
    )
    record = SimRun(default_sim_config(), parse_scenario(text, "bridge.toml")).run()
    passed = [verdict.passed for verdict in record.verdicts]
    assert passed == [True, False, True, True], record.verdicts


def test_the_robots_speed_limit_gates_what_the_bridge_asks_for() -> None:
    """A planner asking 3 m/s of a robot limited to 1.2 m/s: the bridge's speed gate is the
    limit (its own max_speed_mps is 2.0), and the true speed stays near it, not past it."""
    robot = replace(default_sim_config(), limits=LimitsSection(1.2))
    text = (BRIDGE_RUN % 5.5).replace("duration_s = 4.0", "duration_s = 6.0")
    text = text.replace("speed_mps = 1.0", "speed_mps = 3.0")
    run = SimRun(robot, parse_scenario(text, "bridge.toml"))
    assert run.bridge is not None
    assert run.bridge.settings.max_speed_mps == 1.2
    assert run.bridge.settings.max_reverse_speed_mps == 0.8  # already below the limit
    speeds: list[float] = []
    run.runtime.on_cycle.append(lambda _now: speeds.append(run.world.vehicle.state.speed_mps))
    run.run()
    assert 1.0 < max(speeds) <= 1.2
    unlimited = SimRun(default_sim_config(), parse_scenario(text, "bridge.toml"))
    assert unlimited.bridge is not None
    assert unlimited.bridge.settings.max_speed_mps == 2.0  # the bridge's own, below the limit
