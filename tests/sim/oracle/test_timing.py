"""The oracle's two sources of figures: when the controller can have noticed something comes
from the robot file under test (its timeouts, frames and periods); what it must then do, and
how fast, comes from the requirements and never from the file: a file that configures a gentler
handover, a shorter controlled stop or a weaker one is judged by the same figures."""

from __future__ import annotations

from bywire.config import parse_config
from bywire.config.limits import CONTROLLED_STOP_S, HANDOVER_RATE
from bywire.sim.oracle import Cause, OracleTiming
from bywire.sim.oracle.requirements import CONTROLLED_STOP_LIMIT_S, REQUIRED_HANDOVER_RATE

BASE = 'backend = "sim"\n'
OWN_FIGURES = (
    BASE + "[steering]\nhandover_rate_norm_per_s = 0.05\n\n"
    "[stop]\ncontrolled_max_s = 2.0\ncontrolled_min_decel_mps2 = 5.0\n"
)


def test_a_robot_file_s_own_stop_and_handover_figures_do_not_reach_the_oracle() -> None:
    ordinary = OracleTiming.for_robot(parse_config(BASE, "<ordinary>"))
    own = OracleTiming.for_robot(parse_config(OWN_FIGURES, "<own figures>"))
    assert own == ordinary


def test_the_requirement_figures_are_the_most_a_robot_file_may_set() -> None:
    assert HANDOVER_RATE.high == REQUIRED_HANDOVER_RATE
    assert CONTROLLED_STOP_S.high == CONTROLLED_STOP_LIMIT_S


def test_the_deadlines_follow_the_robot_file_s_timeouts() -> None:
    slow = parse_config(BASE + "[timeouts]\nrc_timeout_s = 0.2\n", "<slow link>")
    lost = Cause.RC_LINK_LOST
    shift_s = OracleTiming.for_robot(slow).deadline_s(lost) - OracleTiming().deadline_s(lost)
    assert abs(shift_s - 0.1) < 1e-9
