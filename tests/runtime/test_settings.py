"""The runtime's view of a robot file: what it derives rather than reads."""

from __future__ import annotations

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.control.controller import ControlConfig
from bywire.runtime.settings import RuntimeConfig


def test_the_default_stop_is_the_default_robots() -> None:
    derived = RuntimeConfig.from_robot(default_sim_config()).control.stop
    default = ControlConfig().stop
    assert derived.standstill_hold_s == pytest.approx(default.standstill_hold_s)
    assert derived.controlled_max_s == default.controlled_max_s


def test_a_wider_blind_spot_or_a_weaker_regeneration_holds_a_standstill_longer() -> None:
    # The blind spot: 0.3 m/s + 15 m/s² x 10 ms = 0.45 m/s by default; regeneration 1.5 m/s².
    wider = parse_config("[interlocks]\nspeed_step_tolerance_mps = 0.35\n", "<t>")
    weaker = parse_config("[drive]\nmax_regen_volts = 4.0\n", "<t>")
    assert _hold_s(wider) == pytest.approx(0.5 / 1.5)
    assert _hold_s(weaker) == pytest.approx(0.375)


def _hold_s(robot: RobotConfig) -> float:
    return RuntimeConfig.from_robot(robot).control.stop.standstill_hold_s
