"""A second sender on the movement command's id: a misconfigured node, or an attacker.

It sends between the real computer's frames, each time with the counter the real sender will use
next, so every frame it sends is intact and in sequence, and the real sender's next frame then
repeats it: half the frames on the id are accepted, all of them the impostor's (hazard 10).
"""

from __future__ import annotations

from bywire.hal.ports import CanFrame
from bywire.hal.sim.can_port import SimCanPort
from bywire.hal.sim.hlc import COMMAND_PERIOD_S, SimHigherLevelComputer
from bywire.hal.sim.timers import PeriodicTimer, SimClock
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc, secoc

IMPOSTOR_NODE = "impostor"


class SimImpostor:
    """Sends `count` movement commands with the real sender's next counter, half a period off."""

    def __init__(self, clock: SimClock, port: SimCanPort, real: SimHigherLevelComputer) -> None:
        self._clock = clock
        self._port = port
        self._real = real
        self._timer = PeriodicTimer(clock, COMMAND_PERIOD_S, self._send)
        self._remaining = 0
        self.throttle_norm = 0.8
        self.frames_sent = 0
        self.forge_authenticator = False
        """Also send a cryptographic PDU (SecOC) after each frame: it has no key, so its MAC is
        a guess (deterministic bytes, so runs reproduce)."""

    def start(self, count: int, throttle_norm: float = 0.8) -> None:
        """Send `count` frames asking for `throttle_norm`, the first half a period from now."""
        self._remaining, self.throttle_norm = count, throttle_norm
        self._timer.start(self._clock.now() + COMMAND_PERIOD_S / 2)

    def stop(self) -> None:
        self._remaining = 0
        self._timer.stop()

    def _send(self, _tick_s: float) -> None:
        if self._remaining <= 0:
            self._timer.stop()
            return
        counter = self._real.next_counter(MovementCommand)
        command = MovementCommand(0.0, self.throttle_norm, 0.0, Gear.FORWARD, counter)
        frame_id, payload = dbc.encode_command(command)
        if self._port.send(CanFrame(frame_id, payload)):
            self.frames_sent += 1
            if self.forge_authenticator:
                guess = (self.frames_sent * 0x9E3779B97F4A7C15).to_bytes(16, "little")[:8]
                self._port.send(CanFrame(secoc.auth_id(frame_id), guess))
        self._remaining -= 1
