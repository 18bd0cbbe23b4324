"""The safety supervisor: mode, arming, latched causes, source handover and switch debounce.

One small pure state machine with no clock: the controller turns times into levels (an input is
fresh or stale, a fault holds or not) and passes them in as `SupervisorInputs`; the supervisor
answers with its next `SupervisorState`. Its transition table and invariants are written in
`docs/SAFETY.md`; `tests/sim/verify/test_supervisor_exhaustive.py` checks them on every reachable
state. The rules, in the order `supervisor_step` applies them:

1. **Debounce.** The mode switch's position is taken from plausible RC frames. A frame at STOP
   acts at once; any other position counts only after `debounce_frames` consecutive frames
   show it. A lost or implausible RC link forgets the position.
2. **Latch.** Each `Cause` whose condition holds is added to the latched set: always for the
   ones in `ALWAYS_LATCHING`, and for the CAN-bound ones (`CAN_BOUND`) while the mode is, or is
   becoming, CAN. A remote stop that *arrives* (first frame with the request set) latches in
   any mode; one that is merely still held only stops CAN mode, so the RC operator can always
   take over (R-MUX).
3. **Stop.** Any latched cause, or the switch at STOP, means STOP. While the switch is held at
   STOP (debounced), every cause whose condition is gone is cleared: the operator's
   acknowledgement (a watchdog trip and the power-up latch need nothing more).
4. **Arm.** STOP is left only by an arming event, which either succeeds at that instant or is
   forgotten (nothing cleared, and the switch must pass through STOP again): (a) the operator's
   switch leaves STOP after it was held there; or (b) a CAN re-enable edge while the switch is
   at CAN, which clears only the causes CAN may clear (`CAN_CLEARABLE`) once their conditions are
   gone. Either needs nothing latched, CAN's conditions included when arming into CAN, and the
   commanding source's throttle at zero.
5. **Handover.** Moving the switch between RC and CAN while armed changes the source at once,
   but the new source may apply throttle only after it was seen at zero (bumpless transfer).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace

from bywire.control.stop import StopCategory
from bywire.control.values import slot_init
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode

DEFAULT_DEBOUNCE_FRAMES = 3


class Cause(enum.Enum):
    """Why STOP is latched: one row per cause, with the error flag it keeps up while latched and
    its stop category (`bywire.control.stop`); each has its own clearing rule (below).

    Category 0 (power off at once) where the drive itself is suspect, category 1 (a controlled
    stop: the drive powered to brake, then off) where it is healthy: `docs/SAFETY.md` says why
    for each."""

    # Each member's value is its row; the columns are read by name below. (Not an `__init__`
    # storing them as attributes: mypyc cannot compile an Enum's `__init__`, issue 43.)
    _value_: tuple[str, ErrorFlag, StopCategory]

    @property
    def description(self) -> str:
        return self._value_[0]

    @property
    def flag(self) -> ErrorFlag:
        return self._value_[1]

    @property
    def category(self) -> StopCategory:
        return self._value_[2]

    # nothing drives yet: there is no drive to keep powered
    POWER_UP = (
        "power-up: move the mode switch through STOP to arm",
        ErrorFlag.NOT_ARMED,
        StopCategory.POWER_OFF,
    )
    # the inputs are lost or suspect; the drive is healthy and can brake
    RC_LOST = ("RC frames stopped arriving", ErrorFlag.RC_TIMEOUT, StopCategory.CONTROLLED)
    RC_IMPLAUSIBLE = (
        "RC frame implausible or failsafe",
        ErrorFlag.RC_FAILSAFE,
        StopCategory.CONTROLLED,
    )
    CAN_LOST = (
        "CAN movement commands stale while in CAN mode",
        ErrorFlag.CAN_COMMAND_TIMEOUT,
        StopCategory.CONTROLLED,
    )
    CAN_UNTRUSTED = (
        "a CAN command id carries frames from a second sender or a replay",
        ErrorFlag.CAN_UNTRUSTED,
        StopCategory.CONTROLLED,
    )
    REMOTE_STOP = (
        "remote stop requested over CAN",
        ErrorFlag.REMOTE_STOP,
        StopCategory.CONTROLLED,
    )
    # the drive path itself is suspect: it may not do what it is told
    DAC_FAULT = (
        "DAC writes failing: motors disabled",
        ErrorFlag.DAC_FAULT_STOP,
        StopCategory.POWER_OFF,
    )
    WATCHDOG = (
        "the control loop stalled: watchdog tripped",
        ErrorFlag.WATCHDOG_TRIPPED,
        StopCategory.POWER_OFF,
    )
    # a brake or the steering fails; the drive is healthy, and may be the only brake left
    HYDRO_PRESSURE = (
        "hydraulic brake builds no pressure",
        ErrorFlag.HYDRO_PRESSURE_FAULT,
        StopCategory.CONTROLLED,
    )
    STEERING_ENCODER = (
        "steering does not follow its command",
        ErrorFlag.STEERING_ENCODER_FAULT,
        StopCategory.CONTROLLED,
    )
    # the safety operator's button (or its circuit open): power off, as ISO 13850 asks
    ESTOP = (
        "emergency stop pressed, or its circuit open",
        ErrorFlag.ESTOP_PRESSED,
        StopCategory.POWER_OFF,
    )
    # the loop cannot keep its deadlines: a controlled stop needs the loop to watch it
    TIMING = (
        "a loop pass, a port write or a DAC transfer overran its time budget",
        ErrorFlag.TIMING_FAULT,
        StopCategory.POWER_OFF,
    )


CAUSE_FLAGS: dict[Cause, ErrorFlag] = {cause: cause.flag for cause in Cause}
"""The flag each latched cause keeps up, so a latched STOP always names its cause."""

CAN_BOUND = frozenset({Cause.CAN_LOST, Cause.CAN_UNTRUSTED, Cause.REMOTE_STOP})
"""Conditions that matter only to CAN mode: they latch there and never block arming into RC."""

ALWAYS_LATCHING = frozenset(Cause) - CAN_BOUND - {Cause.POWER_UP}
"""Conditions that latch STOP in every mode."""

CAN_CLEARABLE = frozenset({Cause.CAN_LOST, Cause.REMOTE_STOP})
"""What a CAN re-enable edge may clear; everything else needs the operator's switch."""

ACKNOWLEDGED_BY_ARMING = frozenset({Cause.POWER_UP, Cause.WATCHDOG})
"""Causes with no condition of their own to wait for: the arming event itself clears them."""

DRIVING_MODES = (ControlMode.RC, ControlMode.CAN)


def stop_category(causes: frozenset[Cause]) -> StopCategory:
    """How a STOP for these causes stops: power off if any of them says so, else controlled
    (the operator's switch at STOP with nothing latched is a controlled stop too)."""
    for cause in causes:
        if cause.category is StopCategory.POWER_OFF:
            return StopCategory.POWER_OFF
    return StopCategory.CONTROLLED


@dataclass(frozen=True, slots=True)
class SupervisorConfig:
    """How many consecutive RC frames a switch position needs before it counts (1..50).

    One frame is no debounce; the pure core takes it (the smallest state space, for the
    exhaustive check), a robot file does not (`bywire.config.limits.DEBOUNCE_FRAMES`: 2..50)."""

    debounce_frames: int = DEFAULT_DEBOUNCE_FRAMES

    def __post_init__(self) -> None:
        if not 1 <= self.debounce_frames <= 50:
            raise ValueError(f"debounce_frames must be 1..50, got {self.debounce_frames}")


@dataclass(frozen=True, slots=True)
class SupervisorInputs:
    """What the supervisor sees at one step, as levels and edges; no times.

    `conditions`: every cause whose condition holds now (for the CAN-bound ones: CAN movement
    stale, a command id untrusted, a fresh remote stop request). `switch`: the mode switch of the
    RC frames read at this step (STOP if any of them was at STOP, else the newest's; None while the
    link is lost or implausible); `rc_frame`: such frames are new at this step. `*_throttle_zero`:
    the source's requested throttle is zero (False when the source is missing). The two edges are
    pulses of a new ControlCommand frame. `switch_between`: the STOP read is no position (the
    switch between two, or beyond the end ones): it stops at once, but is no stay at STOP.
    """

    conditions: frozenset[Cause] = frozenset()
    switch: ControlMode | None = None
    rc_frame: bool = False
    rc_throttle_zero: bool = True
    can_throttle_zero: bool = False
    remote_stop_rising: bool = False
    re_enable_edge: bool = False
    switch_between: bool = False

    def __init__(  # noqa: PLR0917
        self,
        conditions: frozenset[Cause] = frozenset(),
        switch: ControlMode | None = None,
        rc_frame: bool = False,
        rc_throttle_zero: bool = True,
        can_throttle_zero: bool = False,
        remote_stop_rising: bool = False,
        re_enable_edge: bool = False,
        switch_between: bool = False,
    ) -> None:
        object.__setattr__(self, "conditions", conditions)
        object.__setattr__(self, "switch", switch)
        object.__setattr__(self, "rc_frame", rc_frame)
        object.__setattr__(self, "rc_throttle_zero", rc_throttle_zero)
        object.__setattr__(self, "can_throttle_zero", can_throttle_zero)
        object.__setattr__(self, "remote_stop_rising", remote_stop_rising)
        object.__setattr__(self, "re_enable_edge", re_enable_edge)
        object.__setattr__(self, "switch_between", switch_between)

    def throttle_zero(self, source: ControlMode) -> bool:
        """Whether `source` (RC or CAN) requests zero throttle now."""
        return self.rc_throttle_zero if source is ControlMode.RC else self.can_throttle_zero


slot_init(SupervisorInputs)


@dataclass(frozen=True, slots=True)
class SupervisorState:
    """Mode, latched causes, the debounced switch and the arming and handover gates.

    `switch` is the debounced position (None until known); `candidate` the position of the newest
    frames and `run_frames` how many in a row showed it (capped at the debounce count). `ready`:
    the switch's latest stay at STOP lasted the debounce, and no arming attempt since.
    `throttle_open`: the commanding source has been seen at zero throttle since it took over.
    """

    mode: ControlMode = ControlMode.STOP
    latched: frozenset[Cause] = frozenset({Cause.POWER_UP})
    switch: ControlMode | None = None
    candidate: ControlMode | None = None
    run_frames: int = 0
    ready: bool = False
    throttle_open: bool = False

    def __init__(  # noqa: PLR0917
        self,
        mode: ControlMode = ControlMode.STOP,
        latched: frozenset[Cause] = frozenset({Cause.POWER_UP}),
        switch: ControlMode | None = None,
        candidate: ControlMode | None = None,
        run_frames: int = 0,
        ready: bool = False,
        throttle_open: bool = False,
    ) -> None:
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "latched", latched)
        object.__setattr__(self, "switch", switch)
        object.__setattr__(self, "candidate", candidate)
        object.__setattr__(self, "run_frames", run_frames)
        object.__setattr__(self, "ready", ready)
        object.__setattr__(self, "throttle_open", throttle_open)

    @property
    def throttle_allowed(self) -> bool:
        """The commanding source may apply throttle."""
        return self.mode is not ControlMode.STOP and self.throttle_open

    @property
    def flags(self) -> ErrorFlag:
        """The error flags of every latched cause."""
        flags = ErrorFlag(0)
        for cause in self.latched:
            flags |= cause.flag
        return flags


slot_init(SupervisorState)


def counting(state: SupervisorState, config: SupervisorConfig) -> bool:
    """Whether the switch's debounce is still counting frames (a position not yet settled, or
    none known): while it counts, every RC frame is a step of rule 1, even one that repeats.
    A switch read between positions counts nothing (STOP, no stay: `_debounced`), and a frame
    that repeats it changes nothing."""
    if state.candidate is None and state.switch is ControlMode.STOP:
        return False
    return state.candidate is not state.switch or state.run_frames < config.debounce_frames


def _debounced(
    state: SupervisorState, inputs: SupervisorInputs, frames: int
) -> tuple[ControlMode | None, ControlMode | None, int]:
    """Rule 1: the new (switch, candidate, run_frames)."""
    if inputs.switch is None:
        if inputs.conditions & {Cause.RC_LOST, Cause.RC_IMPLAUSIBLE}:
            return None, None, 0
        return state.switch, state.candidate, state.run_frames
    if not inputs.rc_frame:
        return state.switch, state.candidate, state.run_frames
    position = inputs.switch
    if inputs.switch_between and position is ControlMode.STOP:
        # STOP at once, but no stay at STOP: a switch read between positions for any time (a
        # worn switch, a calibration off by a little, the RC link back after its failsafe with
        # the switch resting there) once readied an arming that a flick through STOP, shorter
        # than the debounce, then made (bywire verify --draw-robots, seed 2, H1)
        return position, None, 0
    run = min(state.run_frames + 1, frames) if position is state.candidate else 1
    if position is ControlMode.STOP or run >= frames:
        return position, position, run
    return state.switch, position, run


def _latching(target: ControlMode, inputs: SupervisorInputs) -> frozenset[Cause]:
    """Rule 2: the causes that latch at this step when the mode is, or becomes, `target`."""
    causes = inputs.conditions & ALWAYS_LATCHING
    if target is ControlMode.CAN:
        causes |= inputs.conditions & CAN_BOUND
    if inputs.remote_stop_rising:
        causes |= {Cause.REMOTE_STOP}
    return causes


def _cleared(
    latched: frozenset[Cause],
    clearable: frozenset[Cause],
    target: ControlMode,
    now: frozenset[Cause],
) -> frozenset[Cause]:
    """What stays latched after an act that may clear `clearable` towards `target`: a cause goes
    when its condition is gone (CAN-bound conditions matter only to CAN) or it needs no more than
    the act itself (`ACKNOWLEDGED_BY_ARMING`)."""
    relevant = now if target is ControlMode.CAN else now - CAN_BOUND
    gone = {
        cause
        for cause in latched & clearable
        if cause in ACKNOWLEDGED_BY_ARMING or cause not in relevant
    }
    return latched - gone


def _arming_targets(
    state: SupervisorState,
    inputs: SupervisorInputs,
    switch: ControlMode | None,
    settled: bool,
) -> list[tuple[ControlMode, bool]]:
    """Rule 4: the arming events at this step, as (target, made by the operator), the
    operator's first. A CAN re-enable counts only while the switch is settled at CAN."""
    events = []
    if state.switch is ControlMode.STOP and switch in DRIVING_MODES and state.ready:
        events.append((switch, True))
    if inputs.re_enable_edge and switch is ControlMode.CAN and settled:
        events.append((ControlMode.CAN, False))
    return events


def _from_stop(
    state: SupervisorState,
    inputs: SupervisorInputs,
    switch: ControlMode | None,
    held_at_stop: bool,
    debounce: tuple[ControlMode | None, int, bool],
) -> SupervisorState:
    """STOP now: the switch held at STOP clears what is gone; leaving arms, or is forgotten."""
    candidate, run, settled = debounce
    # `ready` belongs to the latest stay at STOP: a new one (a glitch, a bounce) starts it afresh.
    new_stay = inputs.rc_frame and candidate is ControlMode.STOP and run == 1
    ready = ((state.ready and not new_stay) or held_at_stop) and switch is not None
    latched = state.latched | _latching(ControlMode.STOP, inputs)
    if held_at_stop:
        latched = _cleared(latched, latched, ControlMode.STOP, inputs.conditions)
    events = _arming_targets(state, inputs, switch, settled)
    for target, by_operator in events:
        ready = ready and not by_operator  # the operator's attempt is used up either way
        latched |= _latching(target, inputs)
        remaining = (
            latched if by_operator else _cleared(latched, CAN_CLEARABLE, target, inputs.conditions)
        )
        if not remaining and inputs.throttle_zero(target):
            return SupervisorState(target, frozenset(), switch, candidate, run, False, True)
    # None, or every one refused: forgotten, nothing cleared, the switch must pass through STOP.
    return SupervisorState(ControlMode.STOP, latched, switch, candidate, run, ready)


def supervisor_step(
    state: SupervisorState, inputs: SupervisorInputs, config: SupervisorConfig
) -> SupervisorState:
    """The next state. Pure, and with no clock: evaluated on every decision of the controller."""
    if inputs.remote_stop_rising:  # a frame that asks for both: the stop wins
        inputs = replace(inputs, conditions=inputs.conditions | {Cause.REMOTE_STOP})
    switch, candidate, run = _debounced(state, inputs, config.debounce_frames)
    settled = candidate is switch and run >= config.debounce_frames
    held_at_stop = settled and switch is ControlMode.STOP
    if state.mode is ControlMode.STOP:
        return _from_stop(state, inputs, switch, held_at_stop, (candidate, run, settled))
    target = switch if switch in DRIVING_MODES else ControlMode.STOP
    latched = state.latched | _latching(
        state.mode if target is ControlMode.STOP else target, inputs
    )
    if latched or target is ControlMode.STOP:
        return SupervisorState(ControlMode.STOP, latched, switch, candidate, run, held_at_stop)
    handover = target is not state.mode
    throttle_open = (state.throttle_open and not handover) or inputs.throttle_zero(target)
    return SupervisorState(target, latched, switch, candidate, run, False, throttle_open)
