"""The teleop terminal program (textual): keys to CAN commands every 20 ms, reports on screen.

With a gamepad (``gamepad``), each period first applies the pad's events (``PadInput.step``): its
sticks and dead man drive, and the keyboard's other keys still work.

All decisions are in the pure modules (``state``, ``frames``, ``reports``); this shell owns the
bus, the clock and the screen. One send period reads what arrived, sends the three command
frames and advances the state; by default a thread of its own runs it every 20 ms on absolute
deadlines (``sender``), so that the screen's event loop never delays a command, and the screen,
redrawn 10 times a second, shows the gaps it measured. A test passes ``auto_tick=False`` and
calls ``tick()`` (a period, then the screen) from a simulated clock, and ``now`` is that clock.
Reports arrive through a ``can.Notifier`` thread into a ``can.BufferedReader`` (``notifier=False``
polls the bus in ``tick`` instead, for a single-threaded simulation). On exit one period of full
brake goes out; then the commands stop and the controller's CAN timeout takes it to STOP.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import ClassVar, Protocol

import can
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.binding import BindingType
from textual.widgets import Static

from bywire.quit_keys import QUIT_BINDINGS
from bywire.security.session import TRIP_IDS, SecocSigner
from bywire.teleop.frames import SEND_PERIOD_S, Counters, frames
from bywire.teleop.reports import ReportView, command_lines, fold, report_lines, signing_line
from bywire.teleop.sender import PeriodicSender, SendGaps
from bywire.teleop.state import KEYS, TeleopState, advance, help_line, press

KEY_NAMES = frozenset(binding.key for binding in KEYS)
SHOW_PERIOD_S = 0.1  # the screen is redrawn 10 times a second; the sending does not wait on it
ROBOT_TIMEOUT_S = 0.100  # the robot's default CAN command timeout: a longer gap stops it


class PadInput(Protocol):
    """A gamepad (``bywire.teleop.gamepad_device.GamepadDriver``; evdev is imported only there)."""

    def step(self, state: TeleopState, now_s: float) -> TeleopState:
        """The state after the pad's events since the last period."""

    def status(self) -> str:
        """One line for the screen."""


class TeleopApp(App[None]):
    """Drive the robot from the keyboard over ``bus``; ``q`` quits."""

    TITLE = "bywire teleop"
    BINDINGS: ClassVar[list[BindingType]] = [*QUIT_BINDINGS]  # q and Ctrl-C
    CSS = """
    #commands { border: round $accent; padding: 0 1; height: auto; }
    #reports { border: round $primary; padding: 0 1; height: auto; }
    #help { color: $text-muted; padding: 0 1; }
    """

    def __init__(
        self,
        bus: can.BusABC,
        *,
        now: Callable[[], float] = time.monotonic,
        auto_tick: bool = True,
        notifier: bool = True,
        gamepad: PadInput | None = None,
        signer: SecocSigner | None = None,
    ) -> None:
        """`signer`: authenticated commands, each frame followed by its cryptographic PDU."""
        super().__init__()
        self.bus = bus
        self.gamepad = gamepad
        self.signer = signer
        self.state = TeleopState()
        self.counters = Counters()
        self.view = ReportView()
        self.frames_sent = 0
        self.send_errors = 0
        self.freshness_problem: str | None = None
        self._now = now
        self._auto_tick = auto_tick
        self._reader: can.BufferedReader | None = can.BufferedReader() if notifier else None
        self._notifier: can.Notifier | None = None
        self._lock = threading.Lock()  # the state, between the keys and the send thread
        self._sender: PeriodicSender | None = None
        self.gaps = SendGaps(SEND_PERIOD_S, ROBOT_TIMEOUT_S)
        """The intervals between the periods sent, as the screen shows them."""

    def compose(self) -> ComposeResult:
        yield Static(id="commands")
        yield Static(id="reports")
        yield Static(Text(help_line() + "  q/ctrl+c: quit"), id="help")

    def on_mount(self) -> None:
        if self._reader is not None:
            self._notifier = can.Notifier(self.bus, [self._reader], timeout=0.05)
        if self._auto_tick:
            # The commands go out from a thread of their own, never from the screen's loop.
            self._sender = PeriodicSender(self._period, SEND_PERIOD_S, self._now).start()
            self.set_interval(SHOW_PERIOD_S, lambda: self._show(self._now()))
        self._show(self._now())

    def on_unmount(self) -> None:
        if self._sender is not None:
            self._sender.stop()
        with self._lock:
            self._send(replace(self.state, throttle_norm=0.0, brake_norm=1.0))
        if self._notifier is not None:
            self._notifier.stop()

    def on_key(self, event: events.Key) -> None:
        if event.key in KEY_NAMES:
            event.stop()
            event.prevent_default()
            now_s = self._now()
            with self._lock:
                self.state = press(self.state, event.key, now_s)
            self._show(now_s)

    def tick(self) -> None:
        """One send period and the screen after it (a simulation's clock calls this)."""
        self._period()
        self._show(self._now())

    def _period(self) -> None:
        """One send period: take in the reports, send the commands, advance the state."""
        with self._lock:
            now_s = self._now()
            self._receive(now_s)
            if self.gamepad is not None:
                self.state = self.gamepad.step(self.state, now_s)
            self._send(self.state)
            self.state = advance(self.state, now_s)
            self.gaps.sent(now_s)

    def _send(self, state: TeleopState) -> None:
        signer = self.signer
        if signer is not None and not signer.ready:
            return  # nothing can be signed before the robot's trip counter is heard
        period_frames, self.counters = frames(state, self.counters)
        for frame_id, data in period_frames:
            authenticator = None if signer is None else signer.authenticator(frame_id, data)
            if signer is not None and authenticator is None:
                self.send_errors += 1  # unsigned commands are never sent
                continue
            if self._send_frame(frame_id, data) and authenticator is not None:
                self._send_frame(authenticator.arbitration_id, authenticator.data)

    def _send_frame(self, frame_id: int, data: bytes) -> bool:
        message = can.Message(arbitration_id=frame_id, data=data, is_extended_id=False)
        try:
            self.bus.send(message, timeout=SEND_PERIOD_S)
        except can.CanError:
            self.send_errors += 1  # the controller sees a skipped counter and resyncs
            return False
        self.frames_sent += 1
        return True

    def _receive(self, now_s: float) -> None:
        while (message := self._next_message()) is not None:
            if not message.is_error_frame and not message.is_extended_id:
                data = bytes(message.data)
                if self.signer is not None and message.arbitration_id in TRIP_IDS:
                    self._hear(message.arbitration_id, data)
                else:
                    self.view = fold(self.view, message.arbitration_id, data, now_s)

    def _hear(self, frame_id: int, data: bytes) -> None:
        assert self.signer is not None
        try:
            self.signer.hear(frame_id, data)
        except OSError as error:
            self.freshness_problem = f"cannot write the freshness file: {error.strerror}"
        else:
            self.freshness_problem = None

    def _next_message(self) -> can.Message | None:
        if self._reader is not None:
            return self._reader.get_message(timeout=0.0)
        return self.bus.recv(timeout=0.0)

    def _show(self, now_s: float) -> None:
        with self._lock:
            state, view = self.state, self.view
            sent = f"frames sent {self.frames_sent}  send errors {self.send_errors}"
            signer = self.signer
            signing = [] if signer is None else [signing_line(signer, self.freshness_problem)]
        pad = [] if self.gamepad is None else [self.gamepad.status()]
        commands = Text("\n".join([*command_lines(state), sent, *signing, *pad]) + "\n")
        commands.append(self.gaps.line(), style="bold red" if self.gaps.late else "")
        self.query_one("#commands", Static).update(commands)
        self.query_one("#reports", Static).update(Text("\n".join(report_lines(view, now_s))))
