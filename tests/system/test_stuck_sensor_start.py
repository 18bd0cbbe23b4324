"""A start is no stuck sensor (docs/SAFETY.md row 81, found by `bywire verify --draw-robots 12
--budget 1200 --seed 8`, file 1, campaign 32, H1): the wheel-speed check flags a sensor that
reads standstill while the applied throttle is at `interlocks.speed_stuck_throttle_norm` or more
for longer than `speed_stuck_s`. The file set both to 0 (legal then): a standing robot, given
no throttle at all, counted as driven, so a controlled stop that brought the robot to a stand
flagged its sound sensor at once, lost the speed that ends it, and kept the drive powered at
standstill. A threshold too low to move the robot on the flat (0.1: 0.12 m/s² against
0.15 m/s² of drag) does the same to any stick below the drag. The loader now refuses a
threshold and dwell that the class's weakest start on the flat does not pass
(`config/deadlines.py`, 'a start is no stuck sensor'). Judged on the enable line, the flags and
the vehicle's true speed."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.config import RobotConfig, parse_config
from bywire.error_flags import ErrorFlag
from bywire.errors import ConfigError
from tests.system.judged import Judged, armed_in_rc, judged

GRACE_S = 0.55  # H1's standstill grace and a reading's lag: the longest a stop may stay powered
STOP_S = 4.0


def _robot(
    throttle: float, dwell_s: float, *, loader: bool = True, volts: float = 5.0
) -> RobotConfig:
    """A robot whose throttle steps (the quickest the file allows), with the stuck check's two
    keys and the drive's top volts; past the loader if asked, as files were before."""
    text = "[interlocks]\nthrottle_slew_up_per_s = 100\n"
    if loader:
        text += f"speed_stuck_throttle_norm = {throttle}\nspeed_stuck_s = {dwell_s}\n"
        return parse_config(text + f"[drive]\nmax_throttle_volts = {volts}\n", "robot.toml")
    robot = parse_config(text, "robot.toml")
    interlocks = replace(
        robot.interlocks, speed_stuck_throttle_norm=throttle, speed_stuck_s=dwell_s
    )
    limits = replace(robot.drive.limits, max_throttle_volts=volts)
    return replace(robot, interlocks=interlocks, drive=replace(robot.drive, limits=limits))


def _start(robot: RobotConfig, stick: float, *, gear: str = "reverse") -> Judged:
    """Armed on the flat, the stick to `stick` at 0.5 s (reverse: the slower start), then to
    STOP at 4 s."""
    return judged(
        robot,
        armed_in_rc(
            "start",
            6.0,
            f"{{ at_s = 0.5, rc = {{ throttle = {stick} }} }}",
            f'{{ at_s = {STOP_S}, rc = {{ throttle = 0.0, mode = "stop" }} }}',
            gear=gear,
        ),
    )


def _flagged(run: Judged) -> bool:
    return any(s.error_flags & ErrorFlag.SPEED_SENSOR_FAULT for s in run.samples)


def _powered_at_standstill_s(run: Judged, stop_s: float) -> float:
    """How long the motors stayed enabled after the robot came to stand in the stop."""
    after = run.after(stop_s)
    stood_s = next(s.time_s for s in after if s.speed_mps == 0.0)
    powered = [s.time_s for s in after if s.time_s >= stood_s and s.motors_enabled]
    return (max(powered) - stood_s) if powered else 0.0


@pytest.mark.parametrize(
    ("throttle", "dwell_s", "volts"),
    # the nearest safe throttle at 1 s, the dwell at 0.3, the drive's volts at both defaults
    [(0.172, 1.0, 5.0), (0.3, 0.263, 5.0), (0.3, 1.0, 2.853)],
    ids=["least-throttle", "least-dwell", "least-volts"],
)
def test_a_start_at_the_nearest_safe_values_is_no_stuck_sensor(
    throttle: float, dwell_s: float, volts: float
) -> None:
    run = _start(_robot(throttle, dwell_s, volts=volts), throttle)
    assert run.found == set()
    assert not _flagged(run)
    assert max(abs(s.speed_mps) for s in run.after(STOP_S - 0.1)) > 0.1  # it drove
    assert _powered_at_standstill_s(run, STOP_S) < GRACE_S


def test_just_past_the_least_dwell_a_start_is_taken_for_a_stuck_sensor() -> None:
    """The figures are not loose: the same start, past the loader with the dwell a little under
    the nearest safe value, flags the sound sensor and keeps the stop powered at standstill."""
    run = _start(_robot(0.3, 0.2, loader=False), 0.3)
    assert _flagged(run)
    assert _powered_at_standstill_s(run, STOP_S) > GRACE_S
    assert "H1" in run.found


def test_a_drive_capped_below_the_drag_at_the_threshold_took_a_start_for_a_stuck_sensor() -> None:
    """`drive.max_throttle_volts = 1` (legal before, refused now): the default threshold, 0.3,
    gives 0.3 V of the drive's 5 V, which moves nothing; the sound sensor was flagged."""
    with pytest.raises(ConfigError, match="a start is no stuck sensor"):
        _robot(0.3, 1.0, volts=1.0)
    run = _start(_robot(0.3, 1.0, loader=False, volts=1.0), 0.3)
    assert all(s.speed_mps == 0.0 for s in run.samples)
    assert _flagged(run)


def test_a_threshold_below_the_drag_took_a_stalled_stick_for_a_stuck_sensor() -> None:
    """A stick of 0.11 moves nothing on the flat; at a threshold of 0.1 (legal before, refused
    now) the sound sensor was flagged, and the stop after driving on stayed powered."""
    with pytest.raises(ConfigError, match="a start is no stuck sensor"):
        _robot(0.1, 1.0)
    run = judged(
        _robot(0.1, 1.0, loader=False),
        armed_in_rc(
            "stall",
            10.0,
            "{ at_s = 0.5, rc = { throttle = 0.11 } }",
            "{ at_s = 2.5, rc = { throttle = 0.9 } }",
            '{ at_s = 6.5, rc = { throttle = 0.0, mode = "stop" } }',
        ),
    )
    assert all(s.speed_mps == 0.0 for s in run.after(0.5) if s.time_s < 2.5)  # stalled
    assert _flagged(run)
    assert _powered_at_standstill_s(run, 6.5) > GRACE_S
    assert "H1" in run.found


REMOTE_STOP_DOWNHILL = armed_in_rc(
    "remote-stop-downhill",
    6.0,
    "{ at_s = 0.27, world = { grade = -0.05 } }",
    "{ at_s = 2.9, hlc_control = { remote_stop = true, re_enable = false } }",
    "{ at_s = 3.3, hlc_control = { remote_stop = false, re_enable = false } }",
)


def test_the_findings_file_flagged_a_standing_robot() -> None:
    """The finding: both keys at 0 (refused now) on a 5 % downhill, a remote stop: at the
    stand the sound sensor is flagged and the drive stays powered; the default file ends the
    same stop at standstill."""
    with pytest.raises(ConfigError, match="a start is no stuck sensor"):
        _robot(0.0, 0.0)
    before = judged(_robot(0.0, 0.0, loader=False), REMOTE_STOP_DOWNHILL)
    assert max(s.speed_mps for s in before.after(2.5)) > 0.3  # rolling when stopped
    assert _flagged(before)
    assert _powered_at_standstill_s(before, 2.9) > GRACE_S
    assert "H1" in before.found
    default = judged(parse_config("", "robot.toml"), REMOTE_STOP_DOWNHILL)
    assert default.found == set()
    assert not _flagged(default)
    assert _powered_at_standstill_s(default, 2.9) < GRACE_S
