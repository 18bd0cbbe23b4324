"""The CAN port through python-can: any interface, hardware filters, a receive thread, recovery.

Frames for our command ids pass the interface's acceptance filters; a thread receives them into
a queue, stamps them with the clock and wakes it. `send` never blocks and never raises for the
bus: a full transmit queue, bus-off or an unplugged adapter make it return False, counted in
`send_refused`. Bus-off (error frames, `bus.state`) and a lost adapter (receive errors) are
detected by the thread, which re-opens the bus with a growing back-off until it works again;
`link` tells the runtime (down, failed re-opens, failed receives), which reports it.
"""

from __future__ import annotations

import enum
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import can

from bywire.background import OWNER
from bywire.can_frame import CanFrame, check_can_frame
from bywire.errors import HardwareError
from bywire.hal.linux.can_open import BusSettings, open_bus
from bywire.hal.linux.device_errors import reason
from bywire.hal.ports import LinkState

log = logging.getLogger(__name__)
RECEIVE_TIMEOUT_S = 0.1
RETRY_MIN_S = 0.1
RETRY_MAX_S = 2.0
BUS_OFF_REOPEN_S = 1.0  # a bus-off the driver does not recover from by then gets a re-open
RX_CAPACITY = 1024
CAN_ERR_BUSOFF = 0x40  # linux/can/error.h, in an error frame's id
CAN_ERR_RESTARTED = 0x100

BusFactory = Callable[[BusSettings], can.BusABC]


class BusHealth(enum.Enum):
    """What the port knows about its bus."""

    ACTIVE = "active"
    BUS_OFF = "bus-off"
    DOWN = "down"  # adapter gone or interface down; being re-opened


class PythonCanPort:
    """A `CanPort` on a python-can bus; `wake` and `now_s` come from the clock."""

    def __init__(
        self,
        settings: BusSettings,
        wake: Callable[[], None],
        now_s: Callable[[], float],
        *,
        bus_factory: BusFactory = open_bus,
    ) -> None:
        self.settings = settings
        self._accept_ids = frozenset(settings.accept_ids)
        self._wake, self._now_s, self._factory = wake, now_s, bus_factory
        self._rx: deque[CanFrame] = deque()
        self._lock = threading.Lock()
        self._closing = threading.Event()
        self.health = BusHealth.ACTIVE
        self.fault: HardwareError | None = None
        self._bus_off_since_s: float | None = None
        self.frames_sent = self.frames_received = self.send_refused = 0
        self.rx_overflows = self.reopens = self.bus_off_count = 0
        self.receive_failures = self.reopen_failures = 0
        self._bus: can.BusABC | None = self._factory(settings)
        self._thread = OWNER.thread(self._run, name=f"bywire-can-rx {settings}", stop=self.close)

    def send(self, frame: CanFrame) -> bool:
        check_can_frame(frame)
        bus = self._bus
        if bus is None or self.health is BusHealth.DOWN:
            self.send_refused += 1
            return False
        message = can.Message(
            arbitration_id=frame.arbitration_id, data=frame.data, is_extended_id=False
        )
        try:
            bus.send(message, timeout=0.0)
        except (can.CanError, OSError, ValueError) as error:
            self.send_refused += 1
            log.debug("CAN send refused: %s", error)
            return False
        self.frames_sent += 1
        return True

    def receive(self) -> list[CanFrame]:
        with self._lock:
            frames = list(self._rx)
            self._rx.clear()
        return frames

    @property
    def link(self) -> LinkState:
        """Down while bus-off or being re-opened; receives that raised and frames dropped from
        the full queue are failed receives."""
        return LinkState(
            down=self.health is not BusHealth.ACTIVE,
            reopen_failures=self.reopen_failures,
            receive_failures=self.receive_failures + self.rx_overflows,
        )

    def close(self) -> None:
        """Stop the thread and shut the bus down; safe to call again."""
        if self._closing.is_set():
            return
        self._closing.set()
        self._thread.join(timeout=RECEIVE_TIMEOUT_S * 20)
        self._shutdown_bus()

    # --- the receive thread ------------------------------------------------------------------

    def _run(self) -> None:
        retry_s = RETRY_MIN_S
        while not self._closing.is_set():
            bus = self._bus
            if bus is None:
                retry_s = self._reopen(retry_s)
                continue
            try:
                message = bus.recv(RECEIVE_TIMEOUT_S)
            except (can.CanError, OSError, ValueError) as error:
                self.receive_failures += 1
                self._lost(f"receive failed: {reason(error)}")
                continue
            if message is None:
                self._check_state(bus)
            elif message.is_error_frame:
                self._error_frame(message)
            else:
                self._accept(message)

    def _accept(self, message: can.Message) -> None:
        if message.is_extended_id or message.is_remote_frame:
            return
        if self._accept_ids and message.arbitration_id not in self._accept_ids:
            return  # the interface filters in software, or not at all
        frame = CanFrame(message.arbitration_id, bytes(message.data), self._now_s())
        with self._lock:
            if len(self._rx) >= RX_CAPACITY:
                self.rx_overflows += 1
                return
            self._rx.append(frame)
        self.frames_received += 1
        if self.health is BusHealth.BUS_OFF:
            self._recovered("frames arrive again")
        self._wake()

    def _error_frame(self, message: can.Message) -> None:
        if message.arbitration_id & CAN_ERR_BUSOFF:
            self._enter_bus_off()
        elif message.arbitration_id & CAN_ERR_RESTARTED:
            self._recovered("controller restarted")

    def _check_state(self, bus: can.BusABC) -> None:
        try:
            state = bus.state
        except (NotImplementedError, can.CanError, OSError):
            state = can.BusState.ACTIVE
        if state is can.BusState.ERROR:
            self._enter_bus_off()
        elif self._bus_off_for_s() > BUS_OFF_REOPEN_S:
            self._lost("bus-off for too long")

    def _bus_off_for_s(self) -> float:
        since_s = self._bus_off_since_s
        return 0.0 if since_s is None else time.monotonic() - since_s

    def _enter_bus_off(self) -> None:
        if self.health is BusHealth.ACTIVE:
            self.health, self._bus_off_since_s = BusHealth.BUS_OFF, time.monotonic()
            self.bus_off_count += 1
            self.fault = HardwareError(f"CAN {self.settings}: bus-off")
            log.warning("%s", self.fault)

    def _recovered(self, why: str) -> None:
        if self.health is not BusHealth.ACTIVE:
            log.warning("CAN %s: back (%s)", self.settings, why)
        self.health, self.fault, self._bus_off_since_s = BusHealth.ACTIVE, None, None

    def _lost(self, why: str) -> None:
        if self._closing.is_set():
            return
        self.health = BusHealth.DOWN
        self.fault = HardwareError(f"CAN {self.settings}: {why}")
        log.warning("%s; re-opening", self.fault)
        self._shutdown_bus()

    def _reopen(self, retry_s: float) -> float:
        if self._closing.wait(retry_s):
            return retry_s
        try:
            self._bus = self._factory(self.settings)
        except HardwareError as error:
            self.reopen_failures += 1
            log.debug("CAN re-open failed: %s", error)
            return min(retry_s * 2.0, RETRY_MAX_S)
        self.reopens += 1
        self._recovered("re-opened")
        return RETRY_MIN_S

    def _shutdown_bus(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            try:
                bus.shutdown()
            except Exception as error:  # a dead adapter may fail in any way
                log.debug("CAN shutdown: %s", error)

    def __repr__(self) -> str:
        counts: dict[str, Any] = {"sent": self.frames_sent, "refused": self.send_refused}
        return f"PythonCanPort({self.settings}, {self.health.value}, {counts})"
