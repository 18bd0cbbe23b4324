"""The loader's ranges (`config/limits.py`) hold only values the robot can be run with: each test
plays a range's end on the whole simulated robot and judges it on the hardware."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.config.limits import RC_FRAME_PERIOD_S
from bywire.errors import ConfigError
from bywire.protocol import ibus
from tests.system.test_stop_gets_through import level, played

# Found by `bywire verify --draw-robots 12 --seed 0` (file 2), shrunk to these steps: armed by
# RC, then the mode switch moved between the STOP and RC bands (no position: STOP at once).
SWITCH_LEAVES_RC = """
[[event]]
at_s = 0.0
rc = { gear = "forward" }
[[event]]
at_s = 0.2
rc = { mode = "stop" }
[[event]]
at_s = 0.26
rc = { throttle = 0.0, mode = "rc" }
[[event]]
at_s = 1.7
rc = { mode_raw = 1250 }
"""


def test_the_fastest_legal_receiver_still_stops_the_robot_at_once() -> None:
    """SAFETY.md row 58: `[sim] rc_frame_period_s` allowed 1 ms, but a 32-byte IBUS frame takes
    2.78 ms on the 115200-baud line. The simulated receiver queued frames faster than the line
    carried them, so the controller read ever older frames: armed 0.47 s late, and the switch
    leaving RC at 1.7 s still had the motors enabled and the e-brake released 50 ms later (H1;
    failed on 9002ac3). The fastest period the loader accepts now keeps up with the line."""
    robot = parse_config(f'backend = "sim"\n[sim]\nrc_frame_period_s = {RC_FRAME_PERIOD_S.low}\n')
    run = played(SWITCH_LEAVES_RC, 1.8, robot=robot)
    assert level(run, "motors_enable", 0.6)  # armed by RC, not still reading old frames
    assert not level(run, "motors_enable", 1.75)
    assert not level(run, "ebrake_release", 1.75)


def test_a_frame_period_shorter_than_the_line_carries_is_refused_naming_the_range() -> None:
    line_s = ibus.FRAME_LENGTH * ibus.BITS_PER_BYTE / ibus.BAUD_RATE
    assert line_s <= RC_FRAME_PERIOD_S.low < line_s + 0.0001
    with pytest.raises(
        ConfigError,
        match=r"sim\.rc_frame_period_s = 0\.0027: out of range; allowed 0\.0028\.\.0\.1 s",
    ):
        parse_config("[sim]\nrc_frame_period_s = 0.0027\n")
