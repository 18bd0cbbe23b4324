"""A mode switch read between positions is no stay at STOP (docs/SAFETY.md row 72, S11): the
campaign `bywire verify --draw-robots --seed 2` found on a legal robot file (file 3, campaign 133,
H1), judged by the oracle and on the hardware."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.control import supervisor
from bywire.model import ControlMode
from bywire.sim.scenario import parse_scenario
from bywire.sim.verify.campaign import Campaign
from tests.sim.verify.mutants import between_taken_for_a_stay, ready_never_reset_at_stop
from tests.system.judged import Judged, judged

ROBOT = """
[rc.mode_switch]
positions_raw = [1200, 1700, 2200]
band_raw = 20
hysteresis_raw = 87

[timeouts]
rc_timeout_s = 1.0
watchdog_s = 3.218

[sim]
rc_frame_period_s = 0.1
"""

FOUND = """
name = "switch-between-positions"
description = "RC, the switch rested between positions through a failsafe, then a flick via STOP"
duration_s = 5.0
event = [
    { at_s = 0.0, rc = { gear = "forward" } },
    { at_s = 0.2, rc = { mode = "stop" } },
    { at_s = 0.26, rc = { throttle = 0.0, mode = "rc" } },
    { at_s = 1.3, rc = { mode_raw = 1750 } },
    { at_s = 1.4, fault = "rc_failsafe", count = 1 },
    { at_s = 2.4, fault = "rc_failsafe_off", count = 1 },
    { at_s = 3.3, rc = { mode = "stop" } },
    { at_s = 3.36, rc = { throttle = 0.0, mode = "rc" } },
]
"""


def test_a_flick_through_stop_after_resting_between_positions_arms_nothing() -> None:
    """1750 µs lies outside RC's band (1700 ± 20) but within its hysteresis: read as RC while
    held, as no position (STOP) once the failsafe made the receiver forget it. Resting there
    1.2 s once readied an arming, and a 60 ms flick through STOP (one frame at 10 Hz, less than
    the debounce) then armed RC: the drive enabled and the e-brake released with no deliberate
    act (H1). Now the robot stays stopped, and the oracle finds nothing."""
    robot = parse_config(ROBOT)
    observed: list[tuple[float, bool, bool, ControlMode]] = []
    result = Campaign(robot).run_scenario(
        parse_scenario(FOUND, "found"),
        prepare=lambda run: run.runtime.on_cycle.append(
            lambda now: observed.append(
                (
                    now,
                    run.world.vehicle.inputs.motors_enable,
                    run.world.vehicle.inputs.ebrake_release,
                    run.runtime.state.supervisor.mode,
                )
            )
        ),
    )
    assert result.oracle.violations == []
    assert any(mode is ControlMode.RC for now, _, _, mode in observed if now < 1.3)  # it drove
    after = [(enable, released, mode) for now, enable, released, mode in observed if now > 3.5]
    assert after
    assert all(
        (enable, released, mode) == (False, False, ControlMode.STOP)
        for enable, released, mode in after
    )


RESTING = """
name = "switch-resting-between-positions"
description = "RC, then the switch rests between STOP and RC, then goes to RC"
duration_s = 4.0
event = [
    { at_s = 0.0, rc = { gear = "forward" } },
    { at_s = 0.2, rc = { mode = "stop" } },
    { at_s = 0.26, rc = { throttle = 0.0, mode = "rc" } },
    { at_s = 1.3, rc = { mode_raw = 1450 } },
    { at_s = 2.7, rc = { mode = "rc" } },
]
"""


@pytest.mark.parametrize("old_debounce", [False, True])
def test_the_oracle_judges_a_switch_between_positions_as_no_stay_at_stop(
    monkeypatch: pytest.MonkeyPatch, old_debounce: bool
) -> None:
    """`bywire verify` draws a switch between positions: its oracle takes it as STOP without a
    stay, so the old debounce (which took it for one, and armed RC 1.4 s later with no act) is
    an H1 violation in campaigns too, and the robot as it is now is clean."""
    if old_debounce:
        monkeypatch.setattr(supervisor, "_debounced", between_taken_for_a_stay())
    result = Campaign(parse_config(ROBOT)).run_scenario(parse_scenario(RESTING, "resting"))
    found = {violation.invariant.name for violation in result.oracle.violations}
    assert found == ({"H1"} if old_debounce else set())


# Found by `bywire verify` on file 22's robot (10 Hz frames; `--budget 200 --seed 4`,
# campaign 33, H1; docs/SAFETY.md row 75): held at STOP since power-up, the switch rested between
# STOP and RC, came back to STOP for 60 ms, less than a frame, and went on to RC.
BACK_FROM_THE_GAP = """
name = "back-to-stop-from-the-gap"
description = "a stay at STOP, the switch between STOP and RC, back at STOP for {stop_s} s, RC"
duration_s = 10.0
event = [
    {{ at_s = 0.0, rc = {{ gear = "forward" }} }},
    {{ at_s = 8.23, rc = {{ mode_raw = 1250 }} }},
    {{ at_s = 8.93, rc = {{ mode = "stop" }} }},
    {{ at_s = {rc_s}, rc = {{ throttle = 0.0, mode = "rc" }} }},
]
"""
SLOW_FRAMES = "[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 5.0\n\n[sim]\nrc_frame_period_s = 0.1\n"


def back_from_the_gap(stop_s: float) -> str:
    return BACK_FROM_THE_GAP.format(stop_s=stop_s, rc_s=round(8.93 + stop_s, 3))


def _armed_after(run: Judged, from_s: float) -> bool:
    return any(s.motors_enabled and not s.ebrake_engaged for s in run.after(from_s))


@pytest.mark.parametrize(
    ("stop_s", "arms"),
    [(0.06, True), (0.15, False)],
    ids=["no frame showed STOP", "a frame showed STOP"],
)
def test_a_glimpse_of_stop_after_the_gap_arms_only_if_no_frame_showed_it(
    stop_s: float, arms: bool
) -> None:
    """The controller saw the gap, then RC: the stay before the gap still counts (row 72), and
    the move to RC armed, the throttle at zero. The oracle had started a new stay at the
    glimpse of STOP and flagged the arming (H1). A frame that shows STOP after the gap begins a
    new stay, which 150 ms (one or two frames) does not complete: no arming, and none expected."""
    run = judged(parse_config(SLOW_FRAMES), back_from_the_gap(stop_s))
    assert run.found == set()
    assert _armed_after(run, 9.3) is arms


def test_an_arming_on_a_stay_that_a_frame_at_stop_ended_is_still_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The teeth: the hold the gap kept counts only while no frame may have shown STOP."""
    monkeypatch.setattr(supervisor, "_from_stop", ready_never_reset_at_stop())
    run = judged(parse_config(SLOW_FRAMES), back_from_the_gap(0.15))
    assert _armed_after(run, 9.3)
    assert run.found == {"H1"}


def test_a_glimpse_of_stop_no_frame_showed_between_two_gaps_keeps_the_stay_before_them() -> None:
    """As above, but the switch goes back into the gap before RC: the controller saw one gap."""
    events = back_from_the_gap(0.06).replace(
        '{ at_s = 8.99, rc = { throttle = 0.0, mode = "rc" } }',
        "{ at_s = 8.99, rc = { mode_raw = 1250 } },\n    "
        '{ at_s = 9.3, rc = { throttle = 0.0, mode = "rc" } }',
    )
    assert "9.3" in events
    run = judged(parse_config(SLOW_FRAMES), events)
    assert run.found == set()
    assert _armed_after(run, 9.6)
