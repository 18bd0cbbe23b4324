"""A hard stop is no sensor fault (docs/SAFETY.md row 73, found by `bywire verify --draw-robots
--seed 4`, file 9, campaign 4): with `interlocks.speed_step_tolerance_mps = 0` (legal then), a
robot rolling at 0.35 m/s down a 5 % slope, stopped by a failsafe frame with every brake at once,
changed its wheel reading faster between two decisions a moment apart than the check allowed: a
sound sensor was flagged SPEED_SENSOR_FAULT, the controlled stop lost the speed that ends it,
and the motors stayed enabled at standstill, regenerating, until the stop's time bound (H1 at
0.55 s of standstill). The loader now refuses such a tolerance (`config/deadlines.py`, 'a hard
stop is no sensor fault'); at the nearest safe value the same sequence ends the stop at
standstill. Judged on the enable line and the vehicle's true speed."""

from __future__ import annotations

from dataclasses import replace

from bywire.config import RobotConfig, parse_config
from bywire.error_flags import ErrorFlag
from bywire.sim.runner import SimRun
from tests.system.test_stop_gets_through import played

FAILSAFE_DOWNHILL = """
[[event]]
at_s = 0.0
rc = { gear = "forward" }
[[event]]
at_s = 0.0
hlc = { steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" }
[[event]]
at_s = 0.0
world = { grade = -0.05 }
[[event]]
at_s = 0.2
rc = { mode = "stop" }
[[event]]
at_s = 0.26
rc = { throttle = 0.0, mode = "rc" }
[[event]]
at_s = 1.3
fault = "rc_implausible"
count = 1
"""
NEAREST_SAFE = "[interlocks]\nspeed_step_tolerance_mps = 0.075\n"
FAST_TRANSFERS = "[timeouts]\ndac_transfer_budget_s = 0.0005\n"  # the finding's other key
STANDSTILL_GRACE_S = 0.55  # H1's: the longest hold a file may have, and a reading's lag


def _powered_at_standstill_s(run: SimRun) -> float:
    """How long the motors stayed enabled after the robot came to stand in the stop."""
    samples = [s for s in run.record.samples if s.time_s >= 1.3]
    stood_s = next(s.time_s for s in samples if s.speed_mps == 0.0)
    powered = [s.time_s for s in samples if s.time_s >= stood_s and s.motors_enabled]
    return (max(powered) - stood_s) if powered else 0.0


def test_a_hard_stop_at_the_nearest_safe_tolerance_is_no_sensor_fault() -> None:
    run = played(FAILSAFE_DOWNHILL, 2.5, robot=parse_config(NEAREST_SAFE + FAST_TRANSFERS, "t"))
    assert max(s.speed_mps for s in run.record.samples if s.time_s < 1.3) > 0.3  # rolling
    assert not run.record.error_flags_seen & ErrorFlag.SPEED_SENSOR_FAULT
    assert _powered_at_standstill_s(run) < STANDSTILL_GRACE_S


def test_the_legal_before_tolerance_kept_a_standing_robot_powered() -> None:
    """The teeth: the finding's file, past the loader (as it was before), breaks the rule the
    test above holds."""
    safe = parse_config(NEAREST_SAFE + FAST_TRANSFERS, "t")
    before = replace(safe, interlocks=replace(safe.interlocks, speed_step_tolerance_mps=0.0))
    assert isinstance(before, RobotConfig)
    run = played(FAILSAFE_DOWNHILL, 2.5, robot=before)
    assert run.record.error_flags_seen & ErrorFlag.SPEED_SENSOR_FAULT
    assert _powered_at_standstill_s(run) > STANDSTILL_GRACE_S
