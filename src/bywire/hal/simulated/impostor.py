"""A second sender on one of the computer's command ids: a misconfigured node, or an attacker.

It sends between the real computer's frames, each time with the counter the real sender will use
next, so every frame it sends is intact and in sequence, and the real sender's next frame then
repeats it: half the frames on the id are accepted, all of them the impostor's (hazard 10). On
the movement id it asks for throttle; on the lights id it asks for the hazard lights; on any
other (the control id: an idle `bywire teleop`, neither a stop nor a re-enable) it sends its
command row's neutral frame (`bywire.command_table`).

With authentication on it has no key and guesses a MAC (`forge_authenticator`), unless it is
`keyed`: a compromised node that signs with the computer's own key and freshness.

A *forger* (`forge`) answers each of the computer's frames with a frame whose CRC is bad and then
a forgery carrying the counter the computer just used, asking for full right lock: dce19d3's
reader restarted its sequence at the unreadable frame and took the forgery (issue 30). A
*skipping* forger (`skip`) carries the counter after the computer's next instead: the unreadable
frame allowed one skipped counter, and the computer's own next frame then counted as a stale
counter, a miss, not a second sender (issue 41).
"""

from __future__ import annotations

from bywire.can_frame import CanFrame
from bywire.command_table import command_row
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.hlc import COMMAND_PERIOD_S, SimHigherLevelComputer
from bywire.hal.simulated.timers import PeriodicTimer, SimClock
from bywire.model import Command, Gear, LightsCommand, MovementCommand, with_counter
from bywire.protocol import dbc, secoc

IMPOSTOR_NODE = "impostor"


def impostor_node(kind: type[Command]) -> str:
    """The bus node of the second sender on `kind`'s id (the movement id's is `IMPOSTOR_NODE`)."""
    return IMPOSTOR_NODE if kind is MovementCommand else f"{IMPOSTOR_NODE} ({kind.__name__})"


class SimImpostor:
    """Sends `count` commands of one kind with the real sender's next counter, half a period
    off."""

    def __init__(self, clock: SimClock, port: SimCanPort, real: SimHigherLevelComputer) -> None:
        self._clock = clock
        self._port = port
        self._real_sender = real
        self._timer = PeriodicTimer(clock, COMMAND_PERIOD_S, self._send)
        self._remaining = 0
        self.throttle_norm = 0.8
        self.kind: type[Command] = MovementCommand
        self.asks: Command | None = None
        self.keyed = False
        self.forge = False
        self.skip = False
        self.frames_sent = 0
        self.forge_authenticator = False
        """Also send a cryptographic PDU (SecOC) after each frame: without the key its MAC is a
        guess (deterministic bytes, so runs reproduce)."""

    def start(
        self,
        count: int,
        throttle_norm: float = 0.8,
        kind: type[Command] = MovementCommand,
        *,
        keyed: bool = False,
        forge: bool = False,
        skip: bool = False,
        asks: Command | None = None,
    ) -> None:
        """Send `count` frames of `kind` (a movement frame asking for `throttle_norm`), the first
        half a period from now; `keyed`: signed with the computer's key and freshness; `forge`:
        each a bad-CRC frame and a forgery with the counter just used (full right lock); with
        `skip`, with the counter after the computer's next; `asks`: what its frames ask for
        (its counter replaced), instead of the kind's own request."""
        self._remaining, self.throttle_norm = count, throttle_norm
        self.kind, self.keyed, self.forge, self.skip = kind, keyed, forge, skip
        self.asks = asks
        self._timer.start(self._clock.now() + COMMAND_PERIOD_S / 2)

    def stop(self) -> None:
        self._remaining = 0
        self._timer.stop()

    def _command(self, counter: int) -> Command:
        if self.asks is not None:
            return with_counter(self.asks, counter)
        if self.kind is MovementCommand:
            return MovementCommand(0.0, self.throttle_norm, 0.0, Gear.FORWARD, counter)
        if self.kind is LightsCommand:
            return LightsCommand(False, False, True, False, counter)
        return with_counter(command_row(self.kind).neutral, counter)

    def _send(self, _tick_s: float) -> None:
        if self._remaining <= 0:
            self._timer.stop()
            return
        counter = self._real_sender.next_counter(self.kind)
        if self.forge:
            self._forge((counter + (1 if self.skip else -1)) % dbc.COUNTER_MODULUS)
            return
        command = self._command(counter)
        frame_id, payload = dbc.encode_command(command)
        if self._port.send(CanFrame(frame_id, payload)):
            self.frames_sent += 1
            signer = self._real_sender.signer
            authenticator = None
            if self.keyed and signer is not None:  # in the trip the computer heard, if it has
                authenticator = signer.authenticator(frame_id, payload)
            if authenticator is not None:
                self._port.send(authenticator)
            elif self.forge_authenticator:
                guess = (self.frames_sent * 0x9E3779B97F4A7C15).to_bytes(16, "little")[:8]
                self._port.send(CanFrame(secoc.auth_id(frame_id), guess))
        self._remaining -= 1

    def _forge(self, counter: int) -> None:
        """A frame the controller cannot read, then a forgery with `counter`."""
        forged = MovementCommand(1.0, self.throttle_norm, 0.0, Gear.FORWARD, counter)
        frame_id, payload = dbc.encode_command(forged)
        unreadable = payload[:-1] + bytes((payload[-1] ^ 0x5A,))
        if self._port.send(CanFrame(frame_id, unreadable)) and self._port.send(
            CanFrame(frame_id, payload)
        ):
            self.frames_sent += 2
        self._remaining -= 1
