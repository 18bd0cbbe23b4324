"""One 50 Hz period of teleop traffic: the three commands as CAN frames, counter and CRC included.

Pure. Frames go out control first (a remote stop outranks everything), then movement, then lights,
as the simulated higher-level computer sends them; each message has its own rolling counter,
advanced by one modulo 16 per frame, so the controller's sequence check accepts every frame.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.model import ControlCommand, LightsCommand, MovementCommand
from bywire.protocol import dbc
from bywire.teleop.state import TeleopState

SEND_PERIOD_S = dbc.command_period_s()

Frame = tuple[int, bytes]


@dataclass(frozen=True, slots=True)
class Counters:
    """The rolling counter each command's next frame carries."""

    control: int = 0
    movement: int = 0
    lights: int = 0

    def next(self) -> Counters:
        """The counters of the following period."""
        modulus = dbc.COUNTER_MODULUS
        return Counters(
            (self.control + 1) % modulus,
            (self.movement + 1) % modulus,
            (self.lights + 1) % modulus,
        )


def commands(
    state: TeleopState, counters: Counters
) -> tuple[ControlCommand, MovementCommand, LightsCommand]:
    """The three commands ``state`` asks for, with these counters."""
    return (
        ControlCommand(state.remote_stop, state.re_enable, counters.control),
        MovementCommand(
            state.steering_norm,
            state.throttle_norm,
            state.brake_norm,
            state.gear,
            counters.movement,
        ),
        LightsCommand(
            state.turn_left, state.turn_right, state.hazard, state.low_beam, counters.lights
        ),
    )


def frames(state: TeleopState, counters: Counters) -> tuple[list[Frame], Counters]:
    """This period's frames (id, payload) in sending order, and the next period's counters."""
    encoded = [dbc.encode_command(command) for command in commands(state, counters)]
    return encoded, counters.next()
