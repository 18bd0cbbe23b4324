"""Whether a scenario applies to a robot: the optional sensors it needs against those fitted.

A scenario that checks a sensor's fault, or that drives with the interlocks a sensor allows,
says so (`needs_sensors`); on a robot file whose backend fits no such sensor (the Linux backend
opens none yet, `sensors_fitted`) its expectations cannot hold, and `bywire sim` marks it "not
applicable to this robot" rather than FAIL, as `bywire verify` lists the monitor rows apart.
"""

from __future__ import annotations

from bywire.config import RobotConfig
from bywire.hal.hardware import sensors_fitted
from bywire.sim.scenario import SENSORS, Scenario


def not_applicable(scenario: Scenario, robot: RobotConfig) -> str | None:
    """Why `scenario` does not apply to `robot` (one line), or None when it does."""
    if not scenario.needs_sensors or sensors_fitted(robot.backend):
        return None
    needed = " and ".join(SENSORS[name] for name in scenario.needs_sensors)
    return (
        f"not applicable to this robot: it needs {needed}, which the {robot.backend!r} backend"
        " does not fit (run it on the simulator's defaults: without --config)"
    )
