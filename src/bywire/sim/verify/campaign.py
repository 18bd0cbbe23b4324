"""A fault campaign: a sequence of timed actions on the simulated robot, judged by the oracle.

Each step waits its delay, then does one thing an operator, the higher-level computer or the
world can do (`actions.ACTIONS`, whose names and values are `VOCABULARY`).

A campaign is compiled into a scenario (`compile_steps`): the same events `bywire sim
--scenario` plays, so any campaign can be written to a TOML file and replayed exactly. The real
controller runs it on virtual time with its watchdog on the simulated clock; an `OracleWitness`
tells the `HazardOracle` what each event did, and the oracle checks the hardware after every pass
of the loop. Which rows of the supervisor's transition table the campaign took is recorded too.
"""

from __future__ import annotations

import contextlib
import logging
import operator
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import cast

from bywire.config import RobotConfig, default_sim_config
from bywire.control.supervisor import SupervisorState
from bywire.hal.simulated.clock import VirtualClock
from bywire.sim.runner import SimRun
from bywire.sim.scenario import Scenario
from bywire.sim.verify.actions import OPERATOR, TAIL_S, VOCABULARY, compile_steps
from bywire.sim.verify.oracle import HazardOracle, OracleTiming
from bywire.sim.verify.oracle.bridge import BridgeJudge
from bywire.sim.verify.step_events import Step
from bywire.sim.verify.supervisor_check import transition_labels
from bywire.sim.verify.witness import OracleWitness

__all__ = [
    "OPERATOR",
    "TAIL_S",
    "VOCABULARY",
    "Campaign",
    "CampaignResult",
    "Step",
    "TransitionLog",
    "compile_steps",
]

# --- running a campaign ------------------------------------------------------------------------


@dataclass(slots=True)
class CampaignResult:
    """What one campaign did and what the oracle found."""

    oracle: HazardOracle
    simulated_s: float
    events: int
    transitions: set[str]
    scenario: Scenario
    hlc_refused: dict[str, int] = field(default_factory=dict)
    """Command frames the simulated computer never sent, by message (`hlc.refused`): periods
    in which the campaign tested less than it drew."""


class Campaign:
    """One robot (the simulator's, or the one a robot file describes), one sequence of steps,
    one oracle."""

    def __init__(self, robot: RobotConfig | None = None) -> None:
        self.robot = robot or default_sim_config()

    def run(self, steps: Iterable[Step]) -> CampaignResult:
        """Play the steps, then `TAIL_S` more; the oracle has seen every pass."""
        return self.run_scenario(compile_steps(steps, self.robot))

    def run_scenario(
        self, scenario: Scenario, prepare: Callable[[SimRun], None] | None = None
    ) -> CampaignResult:
        """Play a compiled campaign (or any scenario) with the oracle watching; `prepare` is
        called with the run before it starts (a test attaching its own recorders)."""
        run = SimRun(self.robot, scenario)
        if prepare is not None:
            prepare(run)
        clock = cast(VirtualClock, run.world.clock)
        timing = OracleTiming.for_robot(self.robot)
        oracle = HazardOracle(run.world, timing=timing)
        witness = OracleWitness(
            oracle,
            clock,
            scenario.authenticated,
            bridge=run.bridge is not None,
            mapping=self.robot.rc.mapping,
        )
        run.on_event.append(witness)
        if run.bridge is not None:  # the bridge is the computer: its periods, and B1..B3
            bridge = run.bridge
            judge = BridgeJudge(oracle, bridge.settings, lambda: bridge.planner.publishing)
            run.bridge.on_tick.extend((witness.bridge_period, judge.tick))
            run.bridge.on_offer.append(lambda offer: judge.offered(offer.at_s, offer.refusal))
        run.on_exit.append(oracle.exited)
        log = TransitionLog(run)
        run.runtime.on_cycle.append(oracle.observe)
        run.runtime.on_cycle.append(log.observe)
        with _quiet_runtime():  # a campaign's failing DAC at its end is no news: the oracle judges
            run.run()
        return CampaignResult(
            oracle,
            run.duration_s,
            len(scenario.events),
            log.seen,
            scenario,
            dict(sorted(run.world.hlc.refused.items())),
        )


@contextlib.contextmanager
def _quiet_runtime() -> Iterator[None]:
    """The runtime's log (safe writes that failed at its exit, the DAC writes a campaign's fault
    fails) silenced for one campaign: the whole `bywire.runtime` tree, its children included."""
    logger = logging.getLogger("bywire.runtime")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


@dataclass(slots=True)
class TransitionLog:
    """The rows of the supervisor's transition table a running controller took."""

    run: SimRun
    seen: set[str] = field(default_factory=set)
    previous: SupervisorState = field(default_factory=SupervisorState)

    def observe(self, _now: float) -> None:
        state = self.run.runtime.state.supervisor
        # The same state on most passes (no decision taken: nothing compared); a new but equal
        # one on a decision: no row was taken (operator.ne: compiled, != between @value
        # instances is identity, issue 43)
        if state is not self.previous and operator.ne(state, self.previous):
            self.seen.update(transition_labels(self.previous, state))
            self.previous = state
