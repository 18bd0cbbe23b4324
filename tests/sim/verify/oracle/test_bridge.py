"""The bridge's invariants B1..B3 (`sim/verify/oracle/bridge.py`), judged on whole runs: the
bridge's real CAN side on the simulated robot, fed by the simulated planner.

Each finding of issue 41 about the bridge (6, 7, 8) is planted on a bridge whose decisions (or
whose link's refusal count) are bent back into the finding's old behaviour (the held throttle, the
ramp let go at its end, stale commands dropped uncounted): the oracle must flag each. And the
bridge as fixed (`src/bywire/ros2/`) is clean on the very sequences that found them
(`test_the_fixed_bridge_*`).

And the honest behaviour next to each (a bridge that stops on a flagged speed, a ramp that holds
its brake to standstill, refusals that are counted) is not flagged: the oracle must never flag a
correct bridge.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pytest

from bywire.config import default_sim_config, load_config
from bywire.config.speed_limit import LimitsSection
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, WheelSpeedReport
from bywire.ros2 import link, setpoint, stop_ramp
from bywire.ros2.bridge import Activity, BridgeState, Decision, Inputs, bridge_step
from bywire.ros2.setpoint import Refusal, Setpoint, Tally, admit
from bywire.ros2.settings import BridgeSettings
from bywire.ros2.speed_loop import Pedals
from bywire.sim.bridge_refusals import RefusalBooks
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario, scenario_toml
from bywire.sim.verify.engine import (
    Outcome,
    fails_on_replay,
    reproduction,
    run_campaign,
    shrink_failure,
)
from bywire.sim.verify.oracle import Invariant
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.step_events import Step
from bywire.teleop.frames import SEND_PERIOD_S

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


UNLIMITED = replace(default_sim_config(), limits=LimitsSection(None))
"""The simulator's robot as issue 41's findings met it, before its speed limit (issue 44): the
bridge's ramps are judged from 2.0 m/s and more, past the default limit."""


def _run(steps: list[Step]) -> Outcome:
    outcome = run_campaign(UNLIMITED, steps)
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
    """Finding 6's old behaviour: the speed loop's 0.64, held on the flagged speed. The
    controller's own rule (no CAN throttle while SPEED_SENSOR_FAULT is latched) keeps the true
    speed from growing, so B1 judges the throttle the bridge asks for."""

    def runaway(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision):
            decision = _pedals(decision, 0.64, 0.0)  # finding 6's throttle, held
        return state, decision

    bend(runaway)
    outcome = _run(SENSOR_DIES)
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "asks for throttle 0.640" in b1[0].detail
    assert b1[0].expected == {"bridge_throttle_max_norm": 0.0}
    assert not any("up from" in f.detail for f in b1)  # the controller's defence held


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
    """Throttle 0 as it must, but no brake: the robot coasts on, well past the bridge's blind
    bound (`stop_ramp.blind_brake_s`)."""

    def coasts(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision):
            decision = _pedals(decision, 0.0, 0.0)
        return state, decision

    bend(coasts)
    outcome = _run(SENSOR_DIES)
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "still rolling" in b1[0].detail


def test_b1_flags_a_bridge_that_asks_for_a_cruising_throttle_on_a_flagged_speed(
    bend: Callable[[Step_], None],
) -> None:
    """Only the feed-forward map's throttle for 0.5 m/s: the speed would not grow, and the
    controller zeroes it anyway; the bridge asked for it, and B1 says so."""

    def cruises(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if _flagged(inputs, decision):
            decision = _pedals(decision, 0.146, 0.0)
        return state, decision

    bend(cruises)
    b1 = [f for f in _run(SENSOR_DIES).findings if f.invariant == Invariant.B1]
    assert b1
    assert "asks for throttle 0.146" in b1[0].detail


def test_the_fixed_bridge_stops_on_a_dead_wheel_sensor() -> None:
    """Finding 6's sequence on the fixed bridge: throttle 0 and full brake from the flag, clean
    (before the fix, B1 found it: `test_b1_flags_a_bridge_that_holds_its_throttle_*`)."""
    assert _found(_run(SENSOR_DIES)) == set()


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


def _releases_at_the_ramps_end(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
    """Finding 7's old ramp: at `stop_ramp_s` from its start the brake drops to the holding brake,
    whatever the speed."""
    state, decision = bridge_step(state, inputs, settings)
    ramp = state.ramp
    ended = ramp is not None and inputs.now_s - ramp.started_s >= settings.stop_ramp_s
    if decision.activity is Activity.STOPPING and ended:
        decision = _pedals(decision, 0.0, settings.hold_brake)
    return state, decision


def test_b2_flags_the_old_ramp_that_let_go_at_its_end(bend: Callable[[Step_], None]) -> None:
    bend(_releases_at_the_ramps_end)
    outcome = _run(SILENT_AT_SPEED)
    b2 = [f for f in outcome.findings if f.invariant == Invariant.B2]
    assert b2, outcome.findings
    assert "holding brake 0.1" in b2[0].detail
    assert not {i for i in _found(outcome) if i.startswith("H")}


def test_the_fixed_bridge_brakes_its_ramp_to_standstill_at_the_edges() -> None:
    """Finding 7's sequence (`stop_ramp_s = 0.3`, `hold_brake = 0.1`, silent at 2.0 m/s) on the
    fixed bridge: full brake until standstill is shown, clean."""
    assert _found(_run(SILENT_AT_SPEED)) == set()


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


def test_b3_flags_a_link_that_drops_stale_commands_uncounted(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Finding 8's old link: a command is counted only when refused at arrival; one that ages
    past `max_stamp_age_s` while held, or goes late, is dropped without a word."""

    def old_arrived(
        tally: Tally, stored: Setpoint | None, new: Setpoint, settings: BridgeSettings
    ) -> tuple[Tally, Refusal | None]:
        refusal = admit(new, settings)
        return (tally if refusal is None else tally.refuse(refusal, new.arrived_s)), refusal

    monkeypatch.setattr(link, "arrived", old_arrived)
    monkeypatch.setattr(link, "held", lambda tally, *_: tally)
    outcome = _run(LAGGING_STAMPS)
    b3 = [f for f in outcome.findings if f.invariant == Invariant.B3]
    assert b3, outcome.findings
    assert "commands_refused=0" in b3[0].detail


def test_b3_flags_refusals_counted_under_the_wrong_reason(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Stamps refused at arrival for their age, counted (and warned) as LATE: the total grows,
    `refused_stamp_old` does not, and B3 reads the count by reason."""

    def misnamed(
        tally: Tally, stored: Setpoint | None, new: Setpoint, settings: BridgeSettings
    ) -> tuple[Tally, Refusal | None]:
        refusal = admit(new, settings)
        if refusal is None:
            return real_arrived(tally, stored, new, settings)
        return tally.refuse(Refusal.LATE, new.arrived_s), refusal

    real_arrived = setpoint.arrived
    monkeypatch.setattr(link, "arrived", misnamed)
    outcome = _run([*_driving(0.5), Step(0.5, "planner_lag", 0.3), Step(2.0, "planner_lag", 0.0)])
    b3 = [f for f in outcome.findings if f.invariant == Invariant.B3]
    assert b3, outcome.findings
    assert "due stamp_old=" in b3[0].detail


STOPS_ON_A_LATE_HELD_ONE = [
    Step(0.2, "arm", CAN),
    Step(0.15, "bridge_enable"),
    Step(0.1, "planner_link", True),
    Step(0.1, "planner_lag", 0.3),
]
"""`bywire verify --seed 1`, campaign 1903, shrunk: 0.1 s after the planner starts, its stamps
lag 0.3 s, so every new set-point is refused at arrival while the last good one drives on until
it goes late; the bridge then stops with its planner still publishing."""


def _held_before_1903(
    tally: Tally, stored: Setpoint | None, now_s: float, settings: BridgeSettings
) -> Tally:
    """`setpoint.held` before the fix: only a stamp's ageing counted by itself."""
    if stored is None or not tally.pending:
        return tally
    why = setpoint.judge(stored, now_s, settings)
    if why in setpoint.AGEING:
        return replace(tally.refuse(why, now_s), pending=False)
    return tally


def test_b3_flags_a_stop_on_a_held_command_gone_late_counted_only_with_the_next_refusal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(link, "held", _held_before_1903)
    b3 = [f for f in _run(STOPS_ON_A_LATE_HELD_ONE).findings if f.invariant == Invariant.B3]
    assert b3
    assert "the bridge STOPPING" in b3[0].detail


def test_its_reproduction_fails_on_replay_where_the_level_was_already_warn(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The shrunk campaign written as a scenario: `bridge_unshown_drop` now reads B3's count
    too (the level was WARN from the refusals at arrival, so the level alone passed)."""
    monkeypatch.setattr(link, "held", _held_before_1903)
    outcome = _run(STOPS_ON_A_LATE_HELD_ONE)
    finding = next(f for f in outcome.findings if f.invariant == Invariant.B3)
    written = scenario_toml(
        reproduction(UNLIMITED, STOPS_ON_A_LATE_HELD_ONE, finding, "b3").scenario
    )
    record = SimRun(UNLIMITED, parse_scenario(written, "b3.toml")).run()
    assert [verdict.passed for verdict in record.verdicts] == [False]


def test_a_shrunk_finding_says_whether_its_scenario_fails_on_replay(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every reproduction is replayed as `bywire sim --scenario` runs its file, and says so: the
    old `held` planted, the finding's scenario fails; with the scenario's condition blinded
    (as the level-only `bridge_unshown_drop` was for this finding), the check says it does not."""
    monkeypatch.setattr(link, "held", _held_before_1903)
    outcome = _run(STOPS_ON_A_LATE_HELD_ONE)
    assert shrink_failure(UNLIMITED, outcome, "B3", "b3").fails_on_replay is True
    monkeypatch.setattr(RefusalBooks, "period", lambda *_: None)
    assert (
        fails_on_replay(
            UNLIMITED, reproduction(UNLIMITED, outcome.steps, outcome.findings[0], "b3").scenario
        )
        is False
    )


def test_the_fixed_bridge_counts_the_held_command_that_goes_late_under_a_live_planner() -> None:
    assert _found(_run(STOPS_ON_A_LATE_HELD_ONE)) == set()


def test_the_fixed_bridge_counts_and_warns_lagging_stamps() -> None:
    """Finding 8's sequence on the fixed bridge: every command that ages out is counted by its
    reason and `/diagnostics` warns, clean."""
    assert _found(_run(LAGGING_STAMPS)) == set()


ALBERT = Path(__file__).parents[4] / "config" / "albert.toml"
NO_SENSOR_DRIVING = [*_driving(0.5), Step(3.0, "planner_speed", 0.5)]
"""Row 60: albert (the Linux backend opens no wheel sensor), armed into CAN, ~/enable, cmd_vel
0.5 m/s for 3 s."""


@dataclass
class _Seen:
    """What the hardware showed at every pass (the oracle's own reading) and what the bridge
    decided each period."""

    throttle_volts: list[float] = field(default_factory=list)
    speeds_mps: list[float] = field(default_factory=list)
    activities: list[Activity] = field(default_factory=list)
    drivable: list[bool] = field(default_factory=list)


@pytest.fixture
def seen(monkeypatch: pytest.MonkeyPatch) -> _Seen:
    """Record the simulated hardware after each pass (`Outputs.read`, as the oracle reads it)."""
    record = _Seen()
    read = Outputs.read

    def recording(cls: type[Outputs], world: Any) -> Outputs:
        out = read(world)
        record.throttle_volts.append(out.throttle_volts)
        record.speeds_mps.append(out.speed_mps)
        return out

    monkeypatch.setattr(Outputs, "read", classmethod(recording))
    return record


def _ignores_validity(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
    """The bridge before row 60's fix: it reads the WheelSpeedReport's 0 m/s as a measured
    standstill (the validity bit ignored)."""
    wheels = inputs.view.get(WheelSpeedReport)
    if wheels is not None and not wheels.measured_valid:
        latest = dict(inputs.view.latest)
        latest[WheelSpeedReport] = (
            latest[WheelSpeedReport][0],
            replace(wheels, measured_valid=True),
        )
        inputs = replace(inputs, view=replace(inputs.view, latest=latest))
    return bridge_step(state, inputs, settings)


def test_the_bridge_never_drives_a_robot_without_a_wheel_sensor_blind(
    bend: Callable[[Step_], None], seen: _Seen
) -> None:
    """Row 60: albert's WheelSpeedReport says its speed is unknown (`measured_valid` 0), so the
    bridge never trusts the 0: it stays BLIND, asks no throttle, and the throttle line's DAC
    stays at 0 V with the robot standing, in CAN mode and enabled; the oracle is clean. (Before
    the fix the report said 0 m/s and the bridge's loop opened the throttle: 1.3 m/s after
    3.4 s, B1.)"""

    def spy(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        seen.activities.append(decision.activity)
        seen.drivable.append(decision.status.drivable and state.engaged)
        return state, decision

    bend(spy)
    outcome = run_campaign(load_config(ALBERT), NO_SENSOR_DRIVING)
    assert outcome.bridge
    assert _found(outcome) == set(), outcome.findings
    assert any(seen.drivable)  # armed into CAN and enabled: the planner's 0.5 m/s was live
    assert Activity.DRIVING not in seen.activities
    assert Activity.BLIND in seen.activities
    assert seen.throttle_volts
    assert max(seen.throttle_volts) == 0.0
    assert max(abs(speed) for speed in seen.speeds_mps) == 0.0


def test_b1_finds_a_bridge_that_ignores_the_wheel_speed_reports_validity(
    bend: Callable[[Step_], None], seen: _Seen
) -> None:
    """Row 60 planted: the same run with a bridge that takes the unmeasured 0 m/s as standstill.
    Its loop opens the throttle, the robot rolls away, and B1 finds it."""
    bend(_ignores_validity)
    outcome = run_campaign(load_config(ALBERT), NO_SENSOR_DRIVING)
    b1 = [f for f in outcome.findings if f.invariant == Invariant.B1]
    assert b1, outcome.findings
    assert "unknown (no wheel-speed sensor)" in b1[0].detail
    assert max(seen.throttle_volts) > 0.0
    assert max(seen.speeds_mps) > 0.5


def test_b2_passes_full_brake_to_standstill_from_three_metres_a_second_on_the_shortest_ramp(
    bend: Callable[[Step_], None],
) -> None:
    """The edges together (`max_speed_mps = 3`, `stop_ramp_s = 0.3`, `hold_brake = 0.1`): full
    brake needs longer than the ramp from 3 m/s, and the fixed bridge brakes fully until it
    shows standstill, within its own `stop_ramp.stop_bound_s`, which is B2's bound: clean. The
    old ramp, letting go at its end, is flagged in the same run."""
    steps = [
        *_driving(3.0, "fast"),
        Step(8.0, "planner_link", False),
        Step(3.0, "planner_speed", 0.0),
    ]
    assert _found(_run(steps)) == set()
    bend(_releases_at_the_ramps_end)
    assert Invariant.B2 in _found(_run(steps))


def test_b2_judges_the_bridges_own_stated_bound(bend: Callable[[Step_], None]) -> None:
    """A ramp that never lets go but brakes with half the brake: the robot stands long after
    `stop_ramp.stop_bound_s` (B2's bound, plus two periods), and B2 says so with the bound."""

    def half_brake(state: BridgeState, inputs: Inputs, settings: BridgeSettings) -> Any:
        state, decision = bridge_step(state, inputs, settings)
        if decision.activity is Activity.STOPPING and decision.pedals.brake_norm > 0.5:
            decision = _pedals(decision, 0.0, 0.5)
        return state, decision

    bend(half_brake)
    settings = BridgeSettings()
    outcome = _run(
        [*_driving(2.0), Step(6.0, "planner_link", False), Step(3.0, "planner_speed", 0.0)]
    )
    b2 = [f for f in outcome.findings if f.invariant == Invariant.B2]
    assert b2, outcome.findings
    bound_s = stop_ramp.stop_bound_s(2.0, settings) + 2 * SEND_PERIOD_S
    assert f"(bound {bound_s:.2f} s)" in b2[0].detail
