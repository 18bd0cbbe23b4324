"""The supervisor's invariants, checked on one step, and the exhaustive search that checks them.

The invariants are numbered as in `docs/SAFETY.md` (S1…S11) and stated from the rules, not from
the code: each one compares the state before a step, the step's inputs and the state after.
`explore` walks every state the supervisor can reach from power-up, breadth-first, applying
every input of an abstract alphabet to each, and checks every invariant on every transition.
"""

from __future__ import annotations

import itertools
import operator
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

from bywire.control.controller import MONITOR_CAUSES as MONITORED
from bywire.control.supervisor import (
    ACKNOWLEDGED_BY_ARMING,
    ALWAYS_LATCHING,
    CAN_BOUND,
    CAN_CLEARABLE,
    DRIVING_MODES,
    Cause,
    SupervisorConfig,
    SupervisorInputs,
    SupervisorState,
    supervisor_step,
)
from bywire.model import ControlMode

STOP, RC, CAN = ControlMode.STOP, ControlMode.RC, ControlMode.CAN
RC_GONE = frozenset({Cause.RC_LOST, Cause.RC_IMPLAUSIBLE})
SAME_RULES = ALWAYS_LATCHING - RC_GONE - ACKNOWLEDGED_BY_ARMING
"""Causes the supervisor treats alike (latch in any mode, cleared at STOP once gone): every cause
of the table but those whose rules differ (the RC link's, the CAN-bound ones, those arming
acknowledges, power-up). The default search lets DAC_FAULT stand for all of them; `same_rules`
proves they are alike, so a new cause of this kind is a row of `Cause` and nothing here."""

_OWN_RULES_TRANSITIONS = (
    "CAN->RC: handover",
    "CAN->STOP: CAN_LOST latched",
    "CAN->STOP: CAN_UNTRUSTED latched",
    "CAN->STOP: RC_IMPLAUSIBLE latched",
    "CAN->STOP: RC_LOST latched",
    "CAN->STOP: REMOTE_STOP latched",
    "CAN->STOP: WATCHDOG latched",
    "CAN->STOP: the switch at STOP",
    "CAN: throttle opened at zero",
    "CAN_LOST cleared by arming",
    "RC->CAN: handover",
    "RC->STOP: CAN_LOST latched",
    "RC->STOP: CAN_UNTRUSTED latched",
    "RC->STOP: RC_IMPLAUSIBLE latched",
    "RC->STOP: RC_LOST latched",
    "RC->STOP: REMOTE_STOP latched",
    "RC->STOP: WATCHDOG latched",
    "RC->STOP: the switch at STOP",
    "RC: throttle opened at zero",
    "REMOTE_STOP cleared by arming",
    "STOP->CAN: armed by a CAN re-enable",
    "STOP->CAN: armed by the switch",
    "STOP->RC: armed by the switch",
    "STOP: CAN_LOST cleared at STOP",
    "STOP: CAN_LOST latched",
    "STOP: CAN_UNTRUSTED cleared at STOP",
    "STOP: CAN_UNTRUSTED latched",
    "STOP: POWER_UP cleared at STOP",
    "STOP: RC_IMPLAUSIBLE cleared at STOP",
    "STOP: RC_IMPLAUSIBLE latched",
    "STOP: RC_LOST cleared at STOP",
    "STOP: RC_LOST latched",
    "STOP: REMOTE_STOP cleared at STOP",
    "STOP: REMOTE_STOP latched",
    "STOP: WATCHDOG cleared at STOP",
    "STOP: WATCHDOG latched",
    "STOP: arming refused, a cause latched",
    "STOP: arming refused, throttle",
)
"""The rows of the transition table that name no cause of `SAME_RULES`."""

TRANSITIONS: tuple[str, ...] = tuple(
    sorted(
        (
            *_OWN_RULES_TRANSITIONS,
            *(
                label.format(cause.name)
                for cause in SAME_RULES
                for label in (
                    "CAN->STOP: {} latched",
                    "RC->STOP: {} latched",
                    "STOP: {} cleared at STOP",
                    "STOP: {} latched",
                )
            ),
        )
    )
)
"""Every row of the transition table (as `transition_labels` names them) that a step from a
reachable state can take; `tests/sim/verify/test_supervisor_exhaustive.py` proves the list is
exactly what the search reaches. `bywire verify` reports which of them its campaigns took."""

MONITOR_CAUSES = frozenset(cause for _, cause in MONITORED)  # the controller's one list
"""Causes only a monitor raises, and a monitor judges a measurement: on a robot without the
sensors (docs/DEPLOY.md) no step can take a row that names them."""


def transitions_naming(causes: Iterable[Cause]) -> tuple[str, ...]:
    """The rows of `TRANSITIONS` that latch or clear one of `causes`, in table order."""
    names = {cause.name for cause in causes}
    return tuple(label for label in TRANSITIONS if names & set(label.replace(":", "").split()))


Invariant = Callable[[SupervisorState, SupervisorInputs, SupervisorState, int], bool]


def _zero(inputs: SupervisorInputs, source: ControlMode) -> bool:
    """The source's throttle is zero, read from the inputs here rather than by the machine."""
    return inputs.rc_throttle_zero if source is ControlMode.RC else inputs.can_throttle_zero


def _s1_driving_means_nothing_latched(
    _before: SupervisorState, _inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    return after.mode is STOP or not after.latched


def _s2_a_fault_stops_and_latches(
    _before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, frames: int
) -> bool:
    """A trip needs no more than the switch held at STOP: there it is acknowledged at once."""
    faults = inputs.conditions & ALWAYS_LATCHING
    if after.candidate is STOP and after.run_frames >= frames:
        faults -= ACKNOWLEDGED_BY_ARMING
    return not (inputs.conditions & ALWAYS_LATCHING) or (
        after.mode is STOP and faults <= after.latched
    )


def _s3_the_switch_at_stop_stops_at_once(
    _before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    return not (inputs.rc_frame and inputs.switch is STOP) or after.mode is STOP


def _s4_leaving_stop_is_a_deliberate_act_at_zero_throttle(
    before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    if before.mode is not STOP or after.mode is STOP:
        return True
    target = after.mode
    operator = before.switch is STOP and before.ready and inputs.switch is target
    can_edge = target is ControlMode.CAN and inputs.re_enable_edge
    relevant = inputs.conditions if target is ControlMode.CAN else inputs.conditions - CAN_BOUND
    return (operator or can_edge) and _zero(inputs, target) and not relevant


def _s5_a_new_source_is_gated_until_seen_at_zero(
    before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    opened = after.throttle_allowed and not (before.throttle_allowed and before.mode is after.mode)
    return not opened or _zero(inputs, after.mode)


def _s6_can_mode_only_with_can_fresh_trusted_and_not_stopped(
    _before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    return after.mode is not ControlMode.CAN or not inputs.conditions & CAN_BOUND


def _s7_a_remote_stop_that_arrives_stops(
    _before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    return not inputs.remote_stop_rising or after.mode is STOP


def _s8_a_cause_goes_only_by_its_own_rule(
    before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, frames: int
) -> bool:
    held_at_stop = after.candidate is STOP and after.run_frames >= frames
    armed_by_can = after.mode is ControlMode.CAN and before.mode is STOP and inputs.re_enable_edge
    for cause in before.latched - after.latched:
        gone = cause in ACKNOWLEDGED_BY_ARMING or cause not in inputs.conditions
        by_operator = held_at_stop and (gone or cause in CAN_BOUND)
        by_can = armed_by_can and cause in CAN_CLEARABLE and cause not in inputs.conditions
        if not (by_operator or by_can or (after.mode in DRIVING_MODES and before.mode is STOP)):
            return False
    return True


def _s9_a_mode_away_from_stop_was_seen_in_enough_frames(
    before: SupervisorState, _inputs: SupervisorInputs, after: SupervisorState, frames: int
) -> bool:
    if after.mode is before.mode or after.mode is STOP:
        return True
    return after.candidate is after.mode and after.run_frames >= frames


def _s10_a_lost_link_forgets_the_switch(
    _before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    lost = inputs.switch is None and bool(inputs.conditions & RC_GONE)
    return not lost or (after.switch is None and not after.ready and after.mode is STOP)


def _s11_a_switch_between_positions_stops_but_readies_no_arming(
    before: SupervisorState, inputs: SupervisorInputs, after: SupervisorState, _n: int
) -> bool:
    """A frame whose switch lies between positions stops at once (as S3), counts for no stay
    at STOP, and readies no arming that was not ready before it."""
    if not (inputs.rc_frame and inputs.switch_between):
        return True
    return after.mode is STOP and after.candidate is not STOP and (before.ready or not after.ready)


INVARIANTS: dict[str, Invariant] = {
    "S1": _s1_driving_means_nothing_latched,
    "S2": _s2_a_fault_stops_and_latches,
    "S3": _s3_the_switch_at_stop_stops_at_once,
    "S4": _s4_leaving_stop_is_a_deliberate_act_at_zero_throttle,
    "S5": _s5_a_new_source_is_gated_until_seen_at_zero,
    "S6": _s6_can_mode_only_with_can_fresh_trusted_and_not_stopped,
    "S7": _s7_a_remote_stop_that_arrives_stops,
    "S8": _s8_a_cause_goes_only_by_its_own_rule,
    "S9": _s9_a_mode_away_from_stop_was_seen_in_enough_frames,
    "S10": _s10_a_lost_link_forgets_the_switch,
    "S11": _s11_a_switch_between_positions_stops_but_readies_no_arming,
}


def violated(
    before: SupervisorState,
    inputs: SupervisorInputs,
    after: SupervisorState,
    config: SupervisorConfig,
) -> list[str]:
    """The ids of the invariants this step breaks (empty when it keeps them all)."""
    frames = config.debounce_frames
    return [name for name, holds in INVARIANTS.items() if not holds(before, inputs, after, frames)]


def alphabet(causes: Iterable[Cause]) -> tuple[SupervisorInputs, ...]:
    """Every abstract input: no condition or one of `causes`, every switch reading (STOP at
    its position or between positions), frame, throttle and edge; consistent in two respects,
    as the controller makes them: the switch is unknown exactly when the RC link is lost or
    implausible, and only a STOP read may be between positions."""
    conditions = [frozenset[Cause](), *(frozenset({cause}) for cause in causes)]
    switches = ((None, False), (STOP, False), (STOP, True), (RC, False), (CAN, False))
    flags = list(itertools.product((False, True), repeat=5))
    inputs = []
    for condition, (switch, between) in itertools.product(conditions, switches):
        for rc_frame, rc_zero, can_zero, stop_rising, re_enable in flags:
            if (switch is None) != bool(condition & RC_GONE) or (switch is None and rc_frame):
                continue
            inputs.append(
                SupervisorInputs(
                    condition, switch, rc_frame, rc_zero, can_zero, stop_rising, re_enable, between
                )
            )
    return tuple(inputs)


SEARCHED_IN_OWN_RIGHT = frozenset({Cause.DAC_FAULT, Cause.ESTOP})
"""The causes of `SAME_RULES` the default search keeps: DAC_FAULT stands for the others, and the
E-stop is searched itself (issue 44: the exhaustive check covers it, not only by `same_rules`)."""


def reduced_causes() -> tuple[Cause, ...]:
    """Every cause a condition can raise, with DAC_FAULT standing for the rest of `SAME_RULES`
    (but the E-stop: `SEARCHED_IN_OWN_RIGHT`)."""
    return tuple(
        cause
        for cause in Cause
        if cause is not Cause.POWER_UP
        and (cause not in SAME_RULES or cause in SEARCHED_IN_OWN_RIGHT)
    )


def same_rules(causes: Iterable[Cause]) -> bool:
    """Whether every cause in `causes` belongs to exactly the same rule sets (so one may stand
    for the others in the search)."""
    sets = (ALWAYS_LATCHING, CAN_BOUND, CAN_CLEARABLE, ACKNOWLEDGED_BY_ARMING, RC_GONE)
    signatures = {tuple(cause in rule_set for rule_set in sets) for cause in causes}
    return len(signatures) == 1


def transition_labels(before: SupervisorState, after: SupervisorState) -> tuple[str, ...]:
    """The rows of `docs/SAFETY.md`'s transition table one step took, named from the states
    alone (so a running controller's steps can be named too); none when nothing it names
    changed. `TRANSITIONS` lists every one the exhaustive search reaches."""
    source, target = before.mode, after.mode
    new, gone = after.latched - before.latched, before.latched - after.latched
    if source is STOP and target is not STOP:
        how = "the switch" if before.switch is STOP else "a CAN re-enable"
        cleared = tuple(f"{cause.name} cleared by arming" for cause in _ordered(gone))
        return (f"STOP->{target.name}: armed by {how}", *cleared)
    if source is not STOP and target is STOP:
        latched = tuple(f"{source.name}->STOP: {cause.name} latched" for cause in _ordered(new))
        return latched or (f"{source.name}->STOP: the switch at STOP",)
    if source is not target:
        return (f"{source.name}->{target.name}: handover",)
    if source is not STOP:
        opened = after.throttle_open and not before.throttle_open
        return (f"{source.name}: throttle opened at zero",) if opened else ()
    labels = [f"STOP: {cause.name} latched" for cause in _ordered(new)]
    labels += [f"STOP: {cause.name} cleared at STOP" for cause in _ordered(gone)]
    tried = before.ready and before.switch is STOP and after.switch in DRIVING_MODES
    if tried:
        labels.append(
            "STOP: arming refused, " + ("a cause latched" if after.latched else "throttle")
        )
    return tuple(labels)


_RANK = {cause: rank for rank, cause in enumerate(Cause)}
"""Each cause's place in `Cause`, the table's order."""


def _ordered(causes: frozenset[Cause]) -> list[Cause]:
    """`causes` in the table's order. Most steps latch or clear nothing, and an Enum member's
    hash is a Python call: iterating all of `Cause` for an empty set was a third of the
    exhaustive search's time."""
    return sorted(causes, key=_RANK.__getitem__) if causes else []


def expand_same_rules(labels: Iterable[str]) -> set[str]:
    """`labels` with DAC_FAULT's standing for each of `SAME_RULES` (the reduced search)."""
    expanded = set()
    for label in labels:
        names = [cause.name for cause in SAME_RULES] if "DAC_FAULT" in label else ["DAC_FAULT"]
        expanded |= {label.replace("DAC_FAULT", name) for name in names}
    return expanded


@dataclass(slots=True)
class Exploration:
    """What the search saw: states, transitions, the table's rows they took, and every
    violation with the path to it."""

    states: int = 0
    transitions: int = 0
    mode_changes: set[tuple[ControlMode, ControlMode]] = field(default_factory=set)
    labels: set[str] = field(default_factory=set)
    violations: list[tuple[str, list[SupervisorInputs]]] = field(default_factory=list)


def _path(
    parents: dict[SupervisorState, tuple[SupervisorState, SupervisorInputs] | None],
    state: SupervisorState,
) -> Iterator[SupervisorInputs]:
    step = parents[state]
    while step is not None:
        state, inputs = step
        yield inputs
        step = parents[state]


def explore(
    inputs: tuple[SupervisorInputs, ...],
    config: SupervisorConfig,
    max_violations: int = 10,
    checked_against: SupervisorConfig | None = None,
) -> Exploration:
    """Breadth-first from power-up over every reachable state × every input in `inputs`; stops
    early once `max_violations` were found (each with the shortest path to it). The invariants
    are checked against `config` unless `checked_against` says otherwise (a test of the check)."""
    promised = config if checked_against is None else checked_against
    start = SupervisorState()
    parents: dict[SupervisorState, tuple[SupervisorState, SupervisorInputs] | None] = {start: None}
    queue, result = deque([start]), Exploration()
    while queue:
        before = queue.popleft()
        for step_inputs in inputs:
            after = supervisor_step(before, step_inputs, config)
            result.transitions += 1
            result.mode_changes.add((before.mode, after.mode))
            if operator.ne(after, before):  # not !=: compiled, identity for @value (issue 43)
                result.labels.update(transition_labels(before, after))
            for name in violated(before, step_inputs, after, promised):
                path = [*reversed(list(_path(parents, before))), step_inputs]
                result.violations.append((name, path))
                if len(result.violations) >= max_violations:
                    result.states = len(parents)
                    return result
            if after not in parents:
                parents[after] = (before, step_inputs)
                queue.append(after)
    result.states = len(parents)
    return result
