"""The speed limit holds at every limit a robot file may set, not only the default (docs/SAFETY.md
rows 67 and 71): from a standstill 10 % downhill, coasting or at full throttle, the true speed
never passes the limit by more than the requirement's margin (`over_limit_margin_mps`, the bound
`bywire verify`'s H11 holds). At a 0.1 m/s limit the governor once let the robot reach 0.53 m/s
(its cap came down at the rate bound from 1 while the stick asked for 0, and the brake waited
for it), and 0.31 m/s once that was mended (the brake's rate bound): `bywire verify
--draw-robots`, seed 2."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from bywire.sim.verify.oracle.requirements import over_limit_margin_mps

DOWNHILL = """
name = "downhill-from-a-standstill"
description = "armed on a 10 % slope, then coasting or at full throttle"
duration_s = 6.0
event = [
    {{ at_s = 0.0, world = {{ grade = -0.1 }} }},
    {{ at_s = 0.0, rc = {{ mode = "stop", gear = "forward", throttle = 0.0 }} }},
    {{ at_s = 0.3, rc = {{ mode = "rc" }} }},
    {{ at_s = 0.5, rc = {{ throttle = {throttle} }} }},
]
"""


@pytest.mark.parametrize("limit_mps", [0.1, 0.3, 1.0, 2.0, 2.9])
@pytest.mark.parametrize("throttle", [0.0, 1.0])
def test_downhill_the_true_speed_stays_within_the_limit_and_its_margin(
    limit_mps: float, throttle: float
) -> None:
    robot = parse_config(f"[limits]\nmax_speed_mps = {limit_mps}")
    scenario = parse_scenario(DOWNHILL.format(throttle=throttle), "downhill")
    run = SimRun(robot, scenario)
    run.run()
    top_mps = run.record.top_speed_mps
    assert top_mps > limit_mps  # the slope carried the robot past its limit: the governor braked
    assert top_mps <= limit_mps + over_limit_margin_mps(limit_mps), f"{top_mps:.3f} m/s"
