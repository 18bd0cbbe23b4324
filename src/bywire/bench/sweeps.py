"""What the benchmark does to the robot: a new throttle value in every CAN and every IBUS frame.

Each sweep runs on its own timer, half a period after the sender's, so every frame carries the
value set just before it and the next value is set well before the next frame. The values form a
sawtooth, so a value comes back only after ``SWEEP_LEVELS`` frames: a write is then unambiguous.
A listen-only node on the bus keeps every movement command frame, stamped with its last bit.
"""

from __future__ import annotations

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.hlc import COMMAND_PERIOD_S
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.world import SimWorld
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc, ibus

SWEEP_LOW_NORM = 0.10
SWEEP_STEP_NORM = 0.02  # 0.1 V on the throttle DAC: about 20 codes between neighbours
SWEEP_LEVELS = 26  # 0.10 … 0.60
LISTENER_NODE = "bench"


def sawtooth_norm(index: int) -> float:
    """The throttle of the ``index``-th frame: 0.10, 0.12, … 0.60, then 0.10 again."""
    return round(SWEEP_LOW_NORM + (index % SWEEP_LEVELS) * SWEEP_STEP_NORM, 6)


class CanSweep:
    """Gives the higher-level computer a new throttle set-point between two of its frames."""

    def __init__(self, world: SimWorld, period_s: float = COMMAND_PERIOD_S) -> None:
        self._hlc = world.hlc
        self._timer = PeriodicTimer(world.clock, period_s, self._next)
        self._index = 0
        self.active = False

    def start(self, first_s: float) -> None:
        """Tick from ``first_s`` (half a period after the computer's first frame)."""
        self._timer.start(first_s)

    def activate(self) -> None:
        """Sweep from the next tick on."""
        self.active = True

    def _next(self, _tick_s: float) -> None:
        if self.active:
            self._hlc.set_movement(0.0, sawtooth_norm(self._index), 0.0, Gear.FORWARD)
            self._index += 1


class RcSweep:
    """Moves the throttle stick between two IBUS frames and notes when each frame was complete.

    ``frames`` holds ``(completed_s, channels)`` for every frame sent while the sweep was active:
    the time its last stop bit arrived (the UART line's free time right after the frame was
    queued) and the channels it carried.
    """

    def __init__(self, world: SimWorld, period_s: float = ibus.FRAME_PERIOD_S) -> None:
        self._rc = world.rc
        self._uart = world.uart
        self._timer = PeriodicTimer(world.clock, period_s, self._next)
        self._index = 0
        self._pending: tuple[int, tuple[int, ...]] | None = None  # frames_sent, channels set
        self.frames: list[tuple[float, tuple[int, ...]]] = []
        self.active = False

    def start(self, first_s: float) -> None:
        """Tick from ``first_s`` (half a period after the receiver's first frame)."""
        self._timer.start(first_s)

    def activate(self) -> None:
        """Sweep from the next tick on."""
        self.active = True

    def _next(self, _tick_s: float) -> None:
        if not self.active:
            self._pending = None
            return
        rc = self._rc
        if self._pending is not None and rc.frames_sent > self._pending[0]:
            self.frames.append((self._uart.line_free_at_s, self._pending[1]))
        rc.set_throttle(sawtooth_norm(self._index))
        self._index += 1
        self._pending = (rc.frames_sent, rc.channels)


class MovementLog:
    """A listen-only node that keeps every MovementCommand frame crossing the bus."""

    def __init__(self, bus: SimCanBus) -> None:
        port = bus.attach(LISTENER_NODE, accept_ids=(dbc.frame_id(MovementCommand),))
        port.set_listener(self.keep)
        self.frames: list[CanFrame] = []

    def keep(self, frame: CanFrame) -> None:
        """Keep one frame (its timestamp is the instant its last bit left the wire)."""
        self.frames.append(frame)
