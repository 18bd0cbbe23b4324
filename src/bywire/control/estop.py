"""The emergency-stop input: its wiring rule and its debounce, pure and on `now` (issue 44).

The button (or a wireless E-stop receiver's relay) is **normally closed** and the line has a
pull-down: the line reads high only while the circuit is closed, i.e. released. So a press, a
broken wire, an unplugged connector and a dead line all read low, and low is pressed
(`pressed_by_level`). A line that cannot be read at all counts as low (the shell's job).

The debounce is against contact bounce only, and **pressed wins**: one sample showing pressed
holds the condition at once, and it holds until the line has read released for `BOUNCE_S`
without a break. A press is never missed (one shorter than the debounce still latches the
supervisor's ESTOP cause), and a release that bounces does not count as a release until it has
settled, so the operator's re-arm cannot slip through a bounce. The line is sampled once per
decision (every control period at least): a press acts within one control period.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.values import slot_init

BOUNCE_S = 0.020
"""The longest contact bounce the debounce absorbs: mechanical switches and relays settle within
5-20 ms. Not a robot file key: it only delays a *release*, never a press, and no robot has a
reason to tune it."""


def pressed_by_level(level_high: bool) -> bool:
    """The wiring rule: low (open circuit: pressed, a broken wire, a dead line) is pressed."""
    return not level_high


@dataclass(frozen=True, slots=True)
class EstopState:
    """When the line last read pressed (None: never since power-up)."""

    pressed_at_s: float | None = None

    def __init__(self, pressed_at_s: float | None = None) -> None:
        object.__setattr__(self, "pressed_at_s", pressed_at_s)

    def holds(self, now: float, bounce_s: float = BOUNCE_S) -> bool:
        """The condition: pressed at `now`, or not yet released for `bounce_s`."""
        return self.pressed_at_s is not None and now - self.pressed_at_s < bounce_s


slot_init(EstopState)


NOT_PRESSED = EstopState()


def estop_step(state: EstopState, level_high: bool | None, now: float) -> EstopState:
    """The next state after sampling the line at `now` (`level_high` None: no E-stop wired)."""
    if level_high is None or not pressed_by_level(level_high):
        return state
    return EstopState(now)
