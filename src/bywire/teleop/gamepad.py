"""Gamepad teleop, pure: evdev input events in, a new ``TeleopState`` out; no I/O, no clock.

The mapping (``BUTTONS``, ``AXES``; an Xbox-style pad as the Linux ``xpad`` and ``hid-generic``
drivers name its controls, which also writes the ``--help`` table):

    left stick  X       steering, −1 full left … +1 full right (the axis' flat zone is 0)
    right trigger       throttle 0…1            left trigger   brake 0…1
    LB (held)           dead man: while held the sticks and triggers drive; released, or
                        never pressed, or the pad lost: throttle 0, full brake, steering 0
    Y / A / X           gear forward / reverse / neutral (throttle drops to 0)
    B                   remote stop (toggle)    START          re-enable pulse
    d-pad ← / →         turn signal left / right (toggle)
    d-pad ↑ / ↓         low beam / hazard (toggle)

Buttons act on their press (value 1; auto-repeat 2 and release 0 are ignored) through the very
actions of the keyboard's keys (``bywire.teleop.state.press``), so gear, lights, remote stop and
the re-enable pulse behave alike from both.

Throttle re-arms: when the dead man is pressed while the throttle trigger is already pulled, the
throttle stays 0 until the trigger has come back to rest, so catching the button never lunges.
A ``SYN_DROPPED`` (the kernel's buffer overflowed, events lost) counts as a release of the dead
man: the pad's true state is unknown until the operator presses it again.

``drive`` writes the sticks' values into the state each period and marks the drive and steering
keys as touched at ``now``, so ``state.advance``'s keyboard decay never fights a trigger held
still (an unchanged trigger sends no events).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace

from evdev import InputEvent, ecodes

from bywire.teleop.state import KEYS, TeleopState, press

TRIGGER_REST_NORM = 0.05  # a trigger at or below this is at rest (triggers report no flat zone)


@dataclass(frozen=True, slots=True)
class AxisRange:
    """An axis' raw range and its flat (dead) zone, as the device reports it (``AbsInfo``)."""

    minimum: int
    maximum: int
    flat: int = 0


@dataclass(frozen=True, slots=True)
class Control:
    """One pad control: evdev's event type and code, the label in ``--help``, what it does."""

    event_type: int
    code: int
    label: str
    action: str
    direction: int = 1  # for a d-pad (hat) axis: the value that presses this control


DEAD_MAN = Control(ecodes.EV_KEY, ecodes.BTN_TL, "LB (hold)", "dead man: held = drive")
STEERING = Control(ecodes.EV_ABS, ecodes.ABS_X, "left stick", "steering")
THROTTLE = Control(ecodes.EV_ABS, ecodes.ABS_RZ, "right trigger", "throttle")
BRAKE = Control(ecodes.EV_ABS, ecodes.ABS_Z, "left trigger", "brake")
AXES = (STEERING, THROTTLE, BRAKE)

# action: the keyboard key (bywire.teleop.state.KEYS) the control presses
BUTTONS = (
    Control(ecodes.EV_KEY, ecodes.BTN_NORTH, "Y", "f"),
    Control(ecodes.EV_KEY, ecodes.BTN_SOUTH, "A", "r"),
    Control(ecodes.EV_KEY, ecodes.BTN_WEST, "X", "n"),
    Control(ecodes.EV_KEY, ecodes.BTN_EAST, "B", "s"),
    Control(ecodes.EV_KEY, ecodes.BTN_START, "START", "e"),
    Control(ecodes.EV_ABS, ecodes.ABS_HAT0X, "d-pad left", "z", direction=-1),
    Control(ecodes.EV_ABS, ecodes.ABS_HAT0X, "d-pad right", "x", direction=1),
    Control(ecodes.EV_ABS, ecodes.ABS_HAT0Y, "d-pad up", "l", direction=-1),
    Control(ecodes.EV_ABS, ecodes.ABS_HAT0Y, "d-pad down", "h", direction=1),
)
HATS = frozenset(button.code for button in BUTTONS if button.event_type == ecodes.EV_ABS)


@dataclass(frozen=True, slots=True)
class PadState:
    """What the pad holds now: the axes' raw values and ranges, the dead man, the throttle lock.

    ``ranges`` holds every axis the device reports (``AbsInfo``); an axis without a range is
    read as 0 (steering centred, triggers at rest), which is also the state before any event.
    """

    ranges: dict[int, AxisRange] = field(default_factory=dict)
    values: dict[int, int] = field(default_factory=dict)
    dead_man: bool = False
    throttle_locked: bool = False
    connected: bool = True

    def axis(self, control: Control) -> float:
        """A stick as −1…1 (flat zone 0) or a trigger as 0…1 (at rest 0); 0 without a range."""
        span = self.ranges.get(control.code)
        raw = self.values.get(control.code)
        if span is None or raw is None or span.maximum <= span.minimum:
            return 0.0
        if control is STEERING:
            return _stick(raw, span)
        fraction = (raw - span.minimum) / (span.maximum - span.minimum)
        return 0.0 if fraction <= TRIGGER_REST_NORM else min(1.0, round(fraction, 4))


def _stick(raw: int, span: AxisRange) -> float:
    centre = (span.maximum + span.minimum) / 2
    half = (span.maximum - span.minimum) / 2
    offset = raw - centre
    if abs(offset) <= span.flat:
        return 0.0
    live = (abs(offset) - span.flat) / max(half - span.flat, 1e-9)
    return round(max(-1.0, min(1.0, live if offset > 0 else -live)), 4)


def _apply(
    pad: PadState, state: TeleopState, event: InputEvent, now_s: float
) -> tuple[PadState, TeleopState]:
    """One event: the pad's new state, and the teleop state after any button it pressed."""
    kind, code, value = event.type, event.code, event.value
    if kind == ecodes.EV_SYN and code == ecodes.SYN_DROPPED:
        return replace(pad, dead_man=False), state
    if kind == ecodes.EV_KEY and code == DEAD_MAN.code and value in (0, 1):
        pressed = value == 1
        locked = pressed and not pad.dead_man and pad.axis(THROTTLE) > 0.0
        return replace(pad, dead_man=pressed, throttle_locked=locked), state
    if kind == ecodes.EV_ABS:
        if code in HATS:
            state = _hat(pad, state, code, value, now_s)
        pad = replace(pad, values={**pad.values, code: value})
        if pad.throttle_locked and pad.axis(THROTTLE) == 0.0:
            pad = replace(pad, throttle_locked=False)
        return pad, state
    if kind == ecodes.EV_KEY and value == 1:
        for button in BUTTONS:
            if button.event_type == ecodes.EV_KEY and button.code == code:
                state = press(state, button.action, now_s)
    return pad, state


def _hat(pad: PadState, state: TeleopState, code: int, value: int, now_s: float) -> TeleopState:
    """A d-pad direction presses its control when the hat moves onto it, not while it stays."""
    if value == 0 or pad.values.get(code) == value:
        return state
    for button in BUTTONS:
        if button.code == code and button.direction == value:
            state = press(state, button.action, now_s)
    return state


def drive(pad: PadState, state: TeleopState) -> TeleopState:
    """Steering, throttle and brake from the pad: its axes while the dead man is held, else safe."""
    if not (pad.dead_man and pad.connected):
        return replace(state, steering_norm=0.0, throttle_norm=0.0, brake_norm=1.0)
    throttle = 0.0 if pad.throttle_locked else pad.axis(THROTTLE)
    return replace(
        state,
        steering_norm=pad.axis(STEERING),
        throttle_norm=throttle,
        brake_norm=pad.axis(BRAKE),
    )


def step(
    pad: PadState, state: TeleopState, events: Iterable[InputEvent], now_s: float
) -> tuple[PadState, TeleopState]:
    """Every event since the last period, then the axes into the state: one send period's input.

    The state's drive and steering keys count as touched at ``now_s`` (see the module docstring).
    """
    for event in events:
        pad, state = _apply(pad, state, event, now_s)
    state = replace(drive(pad, state), drive_key_at_s=now_s, steer_key_at_s=now_s)
    return pad, state


def disconnected(pad: PadState) -> PadState:
    """The pad after its device went away: the dead man counts as released until it is back."""
    return replace(pad, dead_man=False, connected=False)


def help_lines() -> list[str]:
    """The mapping, one control per line, for ``--help``."""
    labels = {binding.key: binding.label for binding in KEYS}
    lines = [f"  {DEAD_MAN.label:<14} {DEAD_MAN.action}, released = throttle 0, full brake"]
    lines += [f"  {axis.label:<14} {axis.action}" for axis in AXES]
    lines += [f"  {button.label:<14} {labels[button.action]}" for button in BUTTONS]
    return lines
