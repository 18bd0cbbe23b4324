"""`bywire verify` on other teams' numbers: any robot file within the loader's ranges and
free of the unsafe combinations `bywire verify` reports
first, a few campaigns each, finds nothing on the correct robot.

A hand-picked list of other robots (`test_verify.py::OTHER_ROBOTS`) holds the configurations that
once broke something; this draws new ones. Drawing them (`bywire verify` on 46 drawn files,
2026-11-25) found a one-frame switch debounce that let a bouncing switch re-arm the robot (now
refused at load), a STOP that only time revealed engaging the e-brake at a slow brake task's own
tick, and four judgements of the oracle's that flagged a correct robot; its own first long run
found a fifth (docs/SAFETY.md).

Each example runs campaigns, so it takes a tenth of the profile's examples: ten on CI, more under
a long profile (`pytest --hypothesis-profile=long tests/sim/verify/test_other_numbers.py`).
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from bywire.config import RobotConfig, parse_config
from bywire.errors import ConfigError
from bywire.sim.verify.draw import draw_campaign
from bywire.sim.verify.engine import run_campaign
from tests.sim.verify.robot_files import robot_files
from tests.sim.verify.test_verify import (
    HYDROBRAKE_FAILS_AS_THE_OPERATOR_BRAKES,
    SERVO_STUCK_AS_THE_OPERATOR_TURNS,
)

CAMPAIGNS_PER_ROBOT = 3


def _robot(text: str) -> RobotConfig:
    try:
        robot = parse_config(text, "<drawn robot file>")
    except ConfigError:
        assume(False)  # refused at load, naming the key or the deadline: tests/config holds that
        raise
    return robot


@pytest.mark.long
@settings(
    max_examples=max(1, settings().max_examples // 10),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(text=robot_files(), first=st.integers(0, 10_000))
def test_campaigns_on_any_legal_numbers_find_nothing_on_a_correct_robot(
    text: str, first: int
) -> None:
    robot = _robot(text)
    for index in range(first, first + CAMPAIGNS_PER_ROBOT):
        outcome = run_campaign(robot, draw_campaign(0, index), index)
        assert outcome.checks > 0
        finding = outcome.findings[0] if outcome.findings else None
        assert finding is None, (
            f"campaign {index} of seed 0 broke {finding.invariant} at {finding.time_s:.3f} s"
            f" ({finding.detail}); replay with the robot file below and"
            f" `bywire verify --config FILE --seed 0 --budget {index + 1}`:\n{text}"
        )


@settings(
    max_examples=max(1, settings().max_examples // 10),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(text=robot_files())
def test_a_failed_brake_and_a_stuck_servo_are_acted_on_in_time_on_any_legal_numbers(
    text: str,
) -> None:
    # H10 judges with the requirement's figures (0.5 s, 2.0 s), which every file the loader
    # accepts keeps (config/deadlines.py): a boosted steering, a slow brake task or the slowest
    # servo model the deadline allows must not be flagged.
    robot = _robot(text)
    for steps in (HYDROBRAKE_FAILS_AS_THE_OPERATOR_BRAKES, SERVO_STUCK_AS_THE_OPERATOR_TURNS):
        outcome = run_campaign(robot, list(steps))
        assert outcome.checks > 0
        assert outcome.findings == [], (outcome.findings[:1], text)
