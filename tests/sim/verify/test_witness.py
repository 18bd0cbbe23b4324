"""The campaign's witness: what an event applied to the simulated robot means for the outputs.
Here the mode switch left between two positions (issue 41, finding 10): between RC and CAN the
controller holds the position read before for the debounce's frames, then stops; the oracle
must expect the same, neither sooner (a false finding) nor never (a blind one)."""

from __future__ import annotations

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.control import rc_mapping, supervisor
from bywire.model import ControlMode
from bywire.sim.verify.campaign import Step
from bywire.sim.verify.engine import run_campaign
from tests.sim.verify.mutants import can_loss_never_latches, remote_stop_ignored

ROBOT = default_sim_config()
SLOW_DEBOUNCE = parse_config('backend = "sim"\n\n[supervisor]\ndebounce_frames = 5\n', "<robot>")
DRIVING_BY = {
    ControlMode.CAN: [Step(0.3, "arm", ControlMode.CAN), Step(0.4, "can_throttle", 0.6)],
    ControlMode.RC: [Step(0.3, "arm", ControlMode.RC), Step(0.4, "rc_throttle", 0.6)],
}


@pytest.mark.parametrize("robot", [ROBOT, SLOW_DEBOUNCE], ids=["default", "debounce 5"])
@pytest.mark.parametrize("source", [ControlMode.CAN, ControlMode.RC])
@pytest.mark.parametrize("raw", [1750, 1250])
def test_a_switch_left_between_two_positions_is_judged_as_the_controller_reads_it(
    robot: RobotConfig, source: ControlMode, raw: int
) -> None:
    # Before, the witness told the oracle STOP at once for 1750 too, which the controller now
    # reaches after the debounce's frames: with a debounce of 5, H1 on a correct robot.
    steps = [*DRIVING_BY[source], Step(1.0, "switch_between", raw), Step(0.5, "arm", source)]
    outcome = run_campaign(robot, steps)
    assert outcome.checks > 0
    assert outcome.findings == [], outcome.findings[:1]


def test_a_controller_that_holds_a_switch_in_transit_for_ever_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = rc_mapping.mode_position

    def for_ever(
        raw: int, mapping: rc_mapping.RcMapping, held: int | None, transit: int, hold: int
    ) -> tuple[int | None, int]:
        return original(raw, mapping, held, 0, hold)[0], 0

    monkeypatch.setattr(rc_mapping, "mode_position", for_ever)
    steps = [*DRIVING_BY[ControlMode.CAN], Step(1.0, "switch_between", 1750)]
    outcome = run_campaign(ROBOT, steps)
    assert {finding.invariant for finding in outcome.findings} & {"H1"}


RC_DRIVING_STILL = [Step(0.2, "arm", ControlMode.RC), Step(0.15, "rc_throttle", 0.0)]


@pytest.mark.parametrize("silenced_by", ["can_link", "can_cable"])
@pytest.mark.parametrize("gap_s", [0.0, 0.005, 0.015625, 0.02, 0.024])
def test_a_remote_stop_the_computer_fell_silent_before_sending_is_not_demanded(
    silenced_by: str, gap_s: float
) -> None:
    """Found by tests/system/test_sequences.py: a remote stop asked at 0.944 s and the computer
    silent at 0.959 s, before any ControlCommand frame carried it. The robot rightly drove on in
    RC; the oracle demanded the stop (H1, 108 violations). Within a ControlCommand period either
    is right: the frame may or may not have gone out."""
    steps = [
        *RC_DRIVING_STILL,
        Step(0.59375, "remote_stop", True),
        Step(gap_s, silenced_by, False),
        Step(0.5, silenced_by, True),  # back: the request, still held, arrives then
    ]
    outcome = run_campaign(ROBOT, steps)
    assert outcome.checks > 0
    assert outcome.findings == [], outcome.findings[:1]


@pytest.mark.parametrize("gap_s", [0.05, 0.2])
def test_a_controller_that_ignores_a_remote_stop_that_went_out_is_still_found(
    monkeypatch: pytest.MonkeyPatch, gap_s: float
) -> None:
    """The teeth the withdrawal must keep: a request older than a period surely went out."""
    monkeypatch.setattr(supervisor, "_latching", remote_stop_ignored(monkeypatch))
    steps = [*RC_DRIVING_STILL, Step(0.59375, "remote_stop", True), Step(gap_s, "can_link", False)]
    outcome = run_campaign(ROBOT, steps)
    assert {finding.invariant for finding in outcome.findings} & {"H1"}


TO_A_SILENT_CAN = {  # RC armed, the computer silent, then the switch to CAN…
    "by its position": Step(0.3, "switch", ControlMode.CAN),
    "by a pulse in CAN's band": Step(0.3, "switch_between", 2100),  # 2000 ± 150 µs
}


@pytest.mark.parametrize("move", TO_A_SILENT_CAN.values(), ids=TO_A_SILENT_CAN.keys())
@pytest.mark.parametrize("broken", [False, True], ids=["correct", "CAN loss never latches"])
def test_a_move_to_a_silent_can_demands_a_stop_however_the_switch_is_read(
    monkeypatch: pytest.MonkeyPatch, move: Step, broken: bool
) -> None:
    """…the controller must stop once the move counts. Before, only the position's own event
    demanded it: a pulse within CAN's band moved the oracle's switch without a demand, and a
    controller that drove on in a CAN it could not hear went unflagged (docs/SAFETY.md row 74)."""
    if broken:
        can_loss_never_latches(monkeypatch)
    steps = [*RC_DRIVING_STILL, Step(0.3, "can_link", False), move, Step(0.5, "rc_throttle", 0.0)]
    outcome = run_campaign(ROBOT, steps)
    assert outcome.checks > 0
    found = {finding.invariant for finding in outcome.findings}
    assert found == ({"H1"} if broken else set()), outcome.findings[:1]
