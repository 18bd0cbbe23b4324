"""Teleop set-points and pure key handling: keys in, a new ``TeleopState`` out; no I/O, no clock.

Keys (one table, ``KEYS``, which also writes the help line):

    left / right   steer 0.1 left / right          up     release the brake, throttle +0.1
    down           throttle −0.1; at 0: brake +0.25  space  full brake, throttle 0
    f / r / n      gear forward / reverse / neutral (throttle drops to 0)
    z / x          turn signal left / right (toggle; one cancels the other)
    h / l          hazard / low beam (toggle)
    s              remote stop (toggle)          e      re-enable pulse (after a remote stop)

A terminal reports key presses and auto-repeats, never releases, so holding a key is a stream of
presses. Dead man's rule (``advance``): when no drive key (up/down) came for ``HOLD_S`` the
throttle ramps down to 0 at ``THROTTLE_DECAY_PER_S``; when no steering key came for ``HOLD_S`` the
steering returns to the centre at ``STEERING_DECAY_PER_S``. ``HOLD_S`` is longer than a terminal's
auto-repeat delay (about 0.5 s), so a held key never lets go. The brake is never released by decay.

Re-enable acts on a rising edge at the controller, so ``e`` starts a pulse: ``RE_ENABLE_FRAMES``
periods high, then at least one low, and a new ``e`` is ignored until the pulse has ended.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from bywire.model import Gear

STEERING_STEP_NORM = 0.1
THROTTLE_STEP_NORM = 0.1
BRAKE_STEP_NORM = 0.25
HOLD_S = 0.6
THROTTLE_DECAY_PER_S = 0.5
STEERING_DECAY_PER_S = 1.0
RE_ENABLE_FRAMES = 5
NEVER_S = float("-inf")


@dataclass(frozen=True, slots=True)
class TeleopState:
    """What the teleop sends, plus when the operator last touched the drive and steering keys.

    Starts safe: full brake, neutral, no throttle. ``re_enable_pulse`` counts the periods left in
    a re-enable pulse: re-enable is sent high while it is above 1; 1 is the low period after it.
    """

    steering_norm: float = 0.0
    throttle_norm: float = 0.0
    brake_norm: float = 1.0
    gear: Gear = Gear.NEUTRAL
    turn_left: bool = False
    turn_right: bool = False
    hazard: bool = False
    low_beam: bool = False
    remote_stop: bool = False
    re_enable_pulse: int = 0
    drive_key_at_s: float = NEVER_S
    steer_key_at_s: float = NEVER_S
    advanced_at_s: float | None = None

    @property
    def re_enable(self) -> bool:
        """The re-enable bit of the next control command."""
        return self.re_enable_pulse > 1


def _clamp(value: float, low: float, high: float) -> float:
    return min(high, max(low, round(value, 6)))


def _steer(delta_norm: float) -> Callable[[TeleopState, float], TeleopState]:
    def action(state: TeleopState, now_s: float) -> TeleopState:
        steering = _clamp(state.steering_norm + delta_norm, -1.0, 1.0)
        return replace(state, steering_norm=steering, steer_key_at_s=now_s)

    return action


def _throttle_up(state: TeleopState, now_s: float) -> TeleopState:
    throttle = _clamp(state.throttle_norm + THROTTLE_STEP_NORM, 0.0, 1.0)
    return replace(state, throttle_norm=throttle, brake_norm=0.0, drive_key_at_s=now_s)


def _throttle_down(state: TeleopState, now_s: float) -> TeleopState:
    if state.throttle_norm > 0.0:
        throttle = _clamp(state.throttle_norm - THROTTLE_STEP_NORM, 0.0, 1.0)
        return replace(state, throttle_norm=throttle, drive_key_at_s=now_s)
    brake = _clamp(state.brake_norm + BRAKE_STEP_NORM, 0.0, 1.0)
    return replace(state, brake_norm=brake, drive_key_at_s=now_s)


def _full_brake(state: TeleopState, now_s: float) -> TeleopState:
    return replace(state, throttle_norm=0.0, brake_norm=1.0, drive_key_at_s=now_s)


def _gear(gear: Gear) -> Callable[[TeleopState, float], TeleopState]:
    def action(state: TeleopState, _now_s: float) -> TeleopState:
        return replace(state, gear=gear, throttle_norm=0.0)

    return action


def _turn_left(state: TeleopState, _now_s: float) -> TeleopState:
    return replace(state, turn_left=not state.turn_left, turn_right=False)


def _turn_right(state: TeleopState, _now_s: float) -> TeleopState:
    return replace(state, turn_right=not state.turn_right, turn_left=False)


def _hazard(state: TeleopState, _now_s: float) -> TeleopState:
    return replace(state, hazard=not state.hazard)


def _low_beam(state: TeleopState, _now_s: float) -> TeleopState:
    return replace(state, low_beam=not state.low_beam)


def _remote_stop(state: TeleopState, _now_s: float) -> TeleopState:
    return replace(state, remote_stop=not state.remote_stop)


def _re_enable(state: TeleopState, _now_s: float) -> TeleopState:
    if state.re_enable_pulse > 0:
        return state  # a pulse is running: a second press must not merge into it
    return replace(state, re_enable_pulse=RE_ENABLE_FRAMES + 1)


@dataclass(frozen=True, slots=True)
class KeyBinding:
    """One key: textual's key name, the label shown in the help, and what it does."""

    key: str
    label: str
    action: Callable[[TeleopState, float], TeleopState]


KEYS: tuple[KeyBinding, ...] = (
    KeyBinding("left", "steer left", _steer(-STEERING_STEP_NORM)),
    KeyBinding("right", "steer right", _steer(STEERING_STEP_NORM)),
    KeyBinding("up", "throttle +", _throttle_up),
    KeyBinding("down", "throttle − / brake +", _throttle_down),
    KeyBinding("space", "full brake", _full_brake),
    KeyBinding("f", "forward", _gear(Gear.FORWARD)),
    KeyBinding("r", "reverse", _gear(Gear.REVERSE)),
    KeyBinding("n", "neutral", _gear(Gear.NEUTRAL)),
    KeyBinding("z", "turn left", _turn_left),
    KeyBinding("x", "turn right", _turn_right),
    KeyBinding("h", "hazard", _hazard),
    KeyBinding("l", "low beam", _low_beam),
    KeyBinding("s", "remote stop", _remote_stop),
    KeyBinding("e", "re-enable", _re_enable),
)

_ACTIONS = {binding.key: binding.action for binding in KEYS}


def press(state: TeleopState, key: str, now_s: float) -> TeleopState:
    """The state after pressing ``key`` (a textual key name) at ``now_s``; other keys: unchanged."""
    action = _ACTIONS.get(key)
    return state if action is None else action(state, now_s)


def help_line() -> str:
    """Every key with its label, for the status line and ``--help``."""
    return "  ".join(f"{binding.key}: {binding.label}" for binding in KEYS)


def _toward_zero(value: float, step: float) -> float:
    if value > 0.0:
        return max(0.0, value - step)
    return min(0.0, value + step)


def advance(state: TeleopState, now_s: float) -> TeleopState:
    """The state one send period later: dead man's decay since the last call, pulse counted down."""
    elapsed_s = 0.0 if state.advanced_at_s is None else max(0.0, now_s - state.advanced_at_s)
    throttle, steering = state.throttle_norm, state.steering_norm
    if now_s - state.drive_key_at_s > HOLD_S:
        throttle = _toward_zero(throttle, THROTTLE_DECAY_PER_S * elapsed_s)
    if now_s - state.steer_key_at_s > HOLD_S:
        steering = _toward_zero(steering, STEERING_DECAY_PER_S * elapsed_s)
    return replace(
        state,
        throttle_norm=round(throttle, 6),
        steering_norm=round(steering, 6),
        re_enable_pulse=max(0, state.re_enable_pulse - 1),
        advanced_at_s=now_s,
    )
