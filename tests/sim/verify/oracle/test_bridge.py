"""The bridge's invariants B1..B3 (`sim/verify/oracle/bridge.py`), judged on whole runs: the
bridge's real CAN side on the simulated robot, fed by the simulated planner.

Each finding of issue 41 about the bridge (6, 7, 8) is planted twice:

- on a bridge whose decisions are bent into the finding's bad behaviour (`_bent`): the oracle
  must flag it, today and after the bridge is fixed;
- on today's bridge with the finding's parameters (`test_todays_bridge_*`): found now. These
  assert what today's code does; once the bridge's fixes merge they must flip to clean (the
  report of this branch names them).

And the honest behaviour next to each (a bridge that stops on a flagged speed, a ramp that holds
its brake to standstill, refusals that are counted) is not flagged: the oracle must never flag a
correct bridge.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from bywire.config import default_sim_config, load_config
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from bywire.ros2 import link
from bywire.ros2.bridge import Activity, BridgeState, Decision, Inputs, bridge_step
from bywire.ros2.settings import BridgeSettings
from bywire.ros2.speed_loop import Pedals
from bywire.sim.verify.engine import Outcome, run_campaign
from bywire.sim.verify.oracle import Invariant
from bywire.sim.verify.step_events import Step

CAN = ControlMode.CAN
Step_ = Callable[[BridgeState, Inputs, BridgeSettings], tuple[BridgeState, Decision]]


def _driving(speed_mps: float, preset: str = "default") -> list[Step]:
    """The bridge's parameters, the robot armed into CAN, ~/enable, the planner at a speed."""
    return [
        Step(0.0, "bridge", preset),
        Step(0.2, "arm", CAN),
        Step(0.15, "bridge_enable"),
        Step(0.1, "planner_speed", speed_mps),
        Step(0.0, "planner_link", True),
    ]


SENSOR_DIES = [*_driving(0.5), Step(4.0, "wheel_sensor", False), Step(3.0, "planner_speed", 0.5)]
"""Finding 6: cmd_vel 0.5 m/s, the wheel sensor dies while driving."""
SILENT_AT_SPEED = [
    *_driving(2.0, "short_ramp"),  # stop_ramp_s = 0.3, hold_brake = 0.1: both legal
    Step(6.0, "planner_link", False),
    Step(3.0, "planner_link", True),
]
"""Finding 7: a silent planner at 2.0 m/s, the shortest ramp and the lightest holding brake."""
LAGGING_STAMPS = [*_driving(0.5), Step(0.0, "planner_lag", 0.17), Step(3.0, "planner_speed", 0.5)]
"""Finding 8: each stamp 0.17 s old on arrival, 20 messages a second."""


def _found(outcome: Outcome) -> set[str]:
    return {finding.invariant for finding in outcome.findings}


def _run(steps: list[Step]) -> Outcome:
    outcome = run_campaign(default_sim_config(), steps)
    assert outcome.bridge
    return outcome


@pytest.fixture
def bend(monkeypatch: pytest.MonkeyPatch) -> Callable[[Step_], None]:
    """Replace the bridge's decision, as the link takes it, by `bent(state, inputs, settings)`."""

    def install(bent: Step_) -> None:
        monkeypatch.setattr(link, "bridge_step", bent)

    return install


def _pedals(decision: Decision, throttle: float, brake: float) -> Decision:
    return replace(decision, pedals=Pedals(throttle, brake, decision.pedals.gear))


# --- B1: a flagged speed -----------------------------------------------------------------------


def _flagged(inputs: Inputs, decision: Decision) -> bool:
    return bool(decision.status.flags & ErrorFlag.SPEED_SENSOR_FAULT)


def test_b1_flags_a_bridge_that_holds_its_throttle_on_a_flagged_speed(
    bend: Callable[[Step_], None],
) -> None:
    def runaway(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision) and decision.activity is Activity.DRIVING:
            decision = _pedals(decision, 0.64, 0.0)  # finding 6's throttle, held
        return state, decision

    bend(runaway)
    outcome = _run(SENSOR_DIES)
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "up from 0.5" in b1[0].detail
    assert b1[0].expected["speed_max_mps"] == pytest.approx(0.5 + 0.15, abs=0.02)


def test_b1_passes_a_bridge_that_brakes_to_a_stop_on_a_flagged_speed(
    bend: Callable[[Step_], None],
) -> None:
    def stops(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision):
            decision = _pedals(decision, 0.0, 1.0)
        return state, decision

    bend(stops)
    outcome = _run(SENSOR_DIES)
    assert _found(outcome) == set(), outcome.findings


def test_b1_flags_a_bridge_that_never_stops_on_a_flagged_speed(
    bend: Callable[[Step_], None],
) -> None:
    """Throttle only enough to hold the speed: it does not grow, but the robot never stops."""

    def cruises(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision) and decision.activity is Activity.DRIVING:
            decision = _pedals(decision, 0.146, 0.0)  # the feed-forward map's 0.5 m/s
        return state, decision

    bend(cruises)
    outcome = _run(SENSOR_DIES)
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "still rolling" in b1[0].detail


def test_todays_bridge_runs_away_on_a_dead_wheel_sensor_and_b1_finds_it() -> None:
    """Finding 6 on today's bridge (flips to clean with the bridge's fix)."""
    outcome = _run(SENSOR_DIES)
    assert Invariant.B1 in _found(outcome)
    assert not {i for i in _found(outcome) if i.startswith("H")}


# --- B2: the stop ramp -------------------------------------------------------------------------


def test_b2_flags_a_ramp_that_lets_go_while_the_robot_rolls(
    bend: Callable[[Step_], None],
) -> None:
    """Finding 7's behaviour planted on the default parameters: halfway through the ramp's time
    the brake drops to a light brake whatever the speed."""
    started: list[float] = []

    def lets_go(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if decision.activity is not Activity.STOPPING:
            started.clear()
            return state, decision
        started[:] = started or [inputs.now_s]
        if inputs.now_s - started[0] > 0.5 * settings.stop_ramp_s:
            decision = _pedals(decision, 0.0, 0.1)
        return state, decision

    bend(lets_go)
    outcome = _run(
        [*_driving(2.0), Step(6.0, "planner_link", False), Step(3.0, "planner_speed", 0.0)]
    )
    b2 = [f for f in outcome.findings if f.invariant == Invariant.B2]
    assert b2, outcome.findings
    assert "still rolling" in b2[0].detail  # the default hold_brake is 1.0: it is the bound
    assert b2[0].expected == {"speed_max_mps": 0.1}


def test_b2_passes_a_ramp_that_brakes_until_standstill() -> None:
    """The default holding brake (1.0) at the ramp's end: full brake until standstill, from
    the bridge's top speed."""
    steps = [*_driving(2.0), Step(6.0, "planner_link", False), Step(3.0, "planner_speed", 0.0)]
    assert _found(_run(steps)) == set()


def test_todays_bridge_lets_its_ramp_go_at_speed_and_b2_finds_it() -> None:
    """Finding 7 on today's bridge (flips to clean with the bridge's fix)."""
    outcome = _run(SILENT_AT_SPEED)
    b2 = [f for f in outcome.findings if f.invariant == Invariant.B2]
    assert b2, outcome.findings
    assert "holding brake 0.1" in b2[0].detail
    assert not {i for i in _found(outcome) if i.startswith("H")}


# --- B3: refusals shown ------------------------------------------------------------------------


def test_b3_passes_stamps_refused_at_arrival_that_are_counted_and_warned() -> None:
    outcome = _run([*_driving(0.5), Step(0.5, "planner_lag", 0.3), Step(2.0, "planner_lag", 0.0)])
    assert _found(outcome) == set(), outcome.findings


def test_b3_flags_a_bridge_that_drops_live_commands_without_a_word(
    bend: Callable[[Step_], None],
) -> None:
    """Every other period the planner's live set-point is dropped (a stop), nothing counted."""
    periods: list[int] = [0]

    def drops(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        periods[0] += 1
        if inputs.now_s > 1.0 and periods[0] % 2 and inputs.setpoint is not None:
            inputs = replace(inputs, setpoint=None)
        return bridge_step(state, inputs, settings)

    bend(drops)
    outcome = _run([*_driving(0.5), Step(2.0, "planner_speed", 0.5)])
    b3 = [f for f in outcome.findings if f.invariant == Invariant.B3]
    assert b3, outcome.findings
    assert b3[0].expected == {"bridge_unshown_drop": False}


def test_todays_bridge_stalls_silently_on_lagging_stamps_and_b3_finds_it() -> None:
    """Finding 8 on today's bridge (flips to clean with the bridge's fix)."""
    outcome = _run(LAGGING_STAMPS)
    b3 = [f for f in outcome.findings if f.invariant == Invariant.B3]
    assert b3, outcome.findings
    assert "commands_refused=0" in b3[0].detail


def test_todays_bridge_drives_a_robot_without_a_wheel_sensor_blind_and_b1_finds_it() -> None:
    """The speed unknown from the start (albert: the Linux backend opens no wheel sensor): the
    speed loop sees 0 m/s and pushes; B1 holds it to a stop as for a flagged speed (flips to
    clean with a bridge that does not drive blind)."""
    albert = load_config(Path(__file__).parents[4] / "config" / "albert.toml")
    outcome = run_campaign(albert, [*_driving(0.5), Step(3.0, "planner_speed", 0.5)])
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "unknown (no wheel-speed sensor)" in b1[0].detail
    assert not {i for i in _found(outcome) if i.startswith("H")}


def test_b2_passes_full_brake_to_standstill_from_three_metres_a_second_on_the_shortest_ramp(
    bend: Callable[[Step_], None],
) -> None:
    """The edges together (`max_speed_mps = 3`, `stop_ramp_s = 0.3`, `hold_brake = 0.1`) on a
    ramp that brakes fully until its wheel sensor shows standstill (as a fixed bridge might):
    full brake needs longer than the ramp from 3 m/s, and B2's bound allows for that."""

    def brakes_to_standstill(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        rolling = abs(decision.status.speed_mps) > settings.standstill_speed_mps
        if decision.activity is Activity.STOPPING and rolling:
            decision = _pedals(decision, 0.0, 1.0)
        return state, decision

    def lets_go_at_the_ramps_end(
        state: BridgeState, inputs: Inputs, settings: BridgeSettings
    ) -> Any:  # the control: the same run does reach the case
        state, decision = bridge_step(state, inputs, settings)
        if decision.activity is Activity.STOPPING and decision.pedals.brake_norm < 1.0:
            decision = _pedals(decision, 0.0, settings.hold_brake)
        return state, decision

    steps = [
        *_driving(3.0, "fast"),
        Step(8.0, "planner_link", False),
        Step(3.0, "planner_speed", 0.0),
    ]
    bend(lets_go_at_the_ramps_end)
    assert Invariant.B2 in _found(_run(steps))
    bend(brakes_to_standstill)
    outcome = _run(steps)
    assert _found(outcome) == set(), outcome.findings
