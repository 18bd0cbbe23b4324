"""The hardware seam: every port the controller uses, identical on the robot and in the simulator.

Everything above this module (control, runtime) sees only these protocols. Backends live in
`bywire.hal.simulated` (in-memory, virtual time) and `bywire.hal.linux` (python-can, pyserial,
smbus2, sysfs, libgpiod); `bywire.hal.tape` wraps either in taped ports and plays recorded runs
back. Reads never block: the runtime waits on the `Clock`, which wakes it when an input port has
something to read or a deadline has come. The two input ports also say how their own link is
(`LinkState`): the runtime reports it (CAN_BUS_OFF, CAN_OPEN_FAILED, CAN_RX_FAILED,
IBUS_PORT_FAILED); the input timeouts, not this, are what stop the robot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from bywire.can_frame import CanFrame


@dataclass(frozen=True, slots=True)
class LinkState:
    """What an input port knows about its own link, as the runtime reads it on every pass.

    The counts only grow while the port is open, so a reader that compares them with the last
    ones it saw catches a failure that came and went between two reads.
    """

    down: bool = False
    """The port cannot receive now: a CAN controller bus-off, a CAN interface that is down or
    gone, a serial device that is gone (while the backend tries to open it again)."""
    reopen_failures: int = 0
    """Attempts to open the port again, after it was lost, that failed."""
    receive_failures: int = 0
    """Receives that failed (the driver returned an error), and frames dropped because the
    receive queue was full."""


LINK_UP = LinkState()
"""A link with nothing wrong, as every port starts."""


class CanPort(Protocol):
    """A CAN controller: non-blocking send and receive of classic 11-bit frames."""

    def send(self, frame: CanFrame) -> bool:
        """Queue a frame; False when the controller cannot take it now (bus-off, queue full)."""
        ...

    def receive(self) -> list[CanFrame]:
        """Every frame received since the last call, oldest first; never blocks."""
        ...

    @property
    def link(self) -> LinkState:
        """The controller's own state: bus-off or its interface down, failed re-opens and
        receives; never blocks."""
        ...


class ByteStream(Protocol):
    """A serial line: the RC receiver's UART."""

    def read_available(self) -> bytes:
        """Every byte received since the last call (possibly none); never blocks."""
        ...

    @property
    def arrived_at_s(self) -> float | None:
        """When the newest byte the last `read_available` returned arrived, on the clock's time
        (None: the backend cannot tell, or nothing was read). Bytes that waited in a buffer
        while the loop was busy are judged by this, not by when the loop read them."""
        ...

    @property
    def link(self) -> LinkState:
        """The line's own state: the device gone, failed re-opens and reads; never blocks."""
        ...


class I2cDevice(Protocol):
    """One device on an I2C bus, written with raw transfers (the DAC6574)."""

    def write(self, data: bytes) -> None:
        """Write one transfer; raises HardwareError when the device does not acknowledge."""
        ...


class PwmChannel(Protocol):
    """One PWM output with a fixed period (50 Hz for the servo, configured for the brake)."""

    @property
    def period_s(self) -> float:
        """The PWM period in seconds."""
        ...

    def set_pulse(self, pulse_s: float) -> None:
        """Set the high time of each period, in seconds (0 = always low)."""
        ...


class DigitalOut(Protocol):
    """One digital output line."""

    def set(self, level: bool) -> None:
        """Drive the line high (True) or low (False)."""
        ...


class DigitalIn(Protocol):
    """One digital input line, read when asked (the E-stop's, at the control rate)."""

    def get(self) -> bool:
        """The line's level now: True high. Raises HardwareError when it cannot be read."""
        ...


class AnalogInput(Protocol):
    """One measured value from a sensor (a pressure, an angle), in the unit its name says."""

    def read(self) -> float | None:
        """The latest reading, or None when the sensor gives none (unplugged, not ready)."""
        ...


class Clock(Protocol):
    """Monotonic time, and the one place the runtime waits."""

    def now(self) -> float:
        """Seconds on a monotonic time line (virtual or real)."""
        ...

    def wait_until(self, deadline_s: float) -> None:
        """Return at `deadline_s`, or earlier as soon as an input port has something to read."""
        ...
