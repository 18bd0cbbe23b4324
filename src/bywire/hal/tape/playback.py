"""Playback ports: a run record's inputs handed back to the controller at their recorded instants.

No vehicle, transmitter or higher-level computer: the ports hand the controller exactly what it
received in the recorded run, at the recorded instants: the RC UART's bytes and the CAN frames
(each arrival wakes the loop, as the port's interrupt did), the sensors' readings in read order,
the refused sends and DAC writes, and each input port's link state from the read that saw it
change. What the controller writes is kept by simulated outputs (the
DAC checks every frame); `bywire.replay.runner` tapes them and compares with the record.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import Generic, TypeVar

from bywire.can_frame import CanFrame, check_can_frame
from bywire.errors import HardwareError
from bywire.hal.hardware import OUTPUT_NAMES, DigitalOutputs, Hardware
from bywire.hal.ports import LINK_UP, I2cDevice, LinkState
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.dac import SimDac6574
from bywire.hal.simulated.gpio_pwm import SimDigitalOut, SimPwmChannel
from bywire.hal.tape.run_record import RecordedRun, SensorValue

T = TypeVar("T")


class _Arrivals(Generic[T]):
    """Recorded arrivals in time order; `due()` takes every one whose time has come."""

    def __init__(self, clock: VirtualClock, arrivals: Sequence[tuple[float, T]]) -> None:
        self._clock = clock
        self._pending = deque(arrivals)

    def due(self) -> list[T]:
        now, taken = self._clock.now(), []
        while self._pending and self._pending[0][0] <= now:
            taken.append(self._pending.popleft()[1])
        return taken


class _Link:
    """A port's recorded link state: each change from the instant a read first saw it."""

    def __init__(self, clock: VirtualClock, changes: Sequence[tuple[float, LinkState]]) -> None:
        self._changes = _Arrivals(clock, changes)
        self._state = LINK_UP

    def now(self) -> LinkState:
        due = self._changes.due()
        if due:
            self._state = due[-1]
        return self._state


class ReplayByteStream:
    """The RC UART: each recorded read's bytes, at its instant, with its arrival stamp."""

    def __init__(
        self,
        clock: VirtualClock,
        chunks: Sequence[tuple[float, bytes, float | None]],
        links: Sequence[tuple[float, LinkState]] = (),
    ) -> None:
        self._arrivals = _Arrivals(clock, [(t, (data, at)) for t, data, at in chunks])
        self._arrived_at_s: float | None = None
        self._link = _Link(clock, links)

    def read_available(self) -> bytes:
        due = self._arrivals.due()
        if due:
            self._arrived_at_s = due[-1][1]
        return b"".join(data for data, _ in due)

    @property
    def arrived_at_s(self) -> float | None:
        """The recorded stamp of the last read's newest byte (None in records made before
        stamps were recorded: the reader then takes the read's time, as it did then)."""
        return self._arrived_at_s

    @property
    def link(self) -> LinkState:
        """As recorded (a record made before links were recorded: never down)."""
        return self._link.now()


class ReplayCanPort:
    """The CAN port: each recorded receive's frames at its instant; sends refused as recorded."""

    def __init__(
        self,
        clock: VirtualClock,
        batches: Sequence[tuple[float, list[CanFrame]]],
        refused_calls: set[int],
        links: Sequence[tuple[float, LinkState]] = (),
    ) -> None:
        self._arrivals = _Arrivals(clock, batches)
        self._refused_calls = refused_calls
        self._sends = 0
        self._link = _Link(clock, links)

    def send(self, frame: CanFrame) -> bool:
        """Accepted unless the record says this call was refused; FrameError, as every CAN port
        raises it, for a frame classic CAN cannot carry (counted as a call, as the tape counts)."""
        call, self._sends = self._sends, self._sends + 1
        check_can_frame(frame)
        return call not in self._refused_calls

    def receive(self) -> list[CanFrame]:
        return [frame for batch in self._arrivals.due() for frame in batch]

    @property
    def link(self) -> LinkState:
        """As recorded (a record made before links were recorded: never down)."""
        return self._link.now()


class ReplayDac:
    """The DAC: a simulated DAC6574 (it checks every frame) that refuses the recorded writes
    and hangs in the recorded ones for as long as they hung (the clock's timers run meanwhile,
    the watchdog's among them)."""

    def __init__(
        self,
        inner: I2cDevice,
        refused_calls: set[int],
        *,
        stalls: tuple[VirtualClock, dict[int, float]] | None = None,
    ) -> None:
        """`stalls`: the clock, and for each call that hung when it returned (clock time)."""
        self._inner, self._refused_calls = inner, refused_calls
        self._stalls = stalls
        self._writes = 0

    def write(self, data: bytes) -> None:
        call, self._writes = self._writes, self._writes + 1
        if self._stalls is not None and call in self._stalls[1]:
            clock, returned_s = self._stalls[0], self._stalls[1][call]
            while clock.now() < returned_s:
                clock.wait_until(returned_s)
        if call in self._refused_calls:
            raise HardwareError("DAC6574: no acknowledge (as recorded)")
        self._inner.write(data)


class _ReadOrder:
    """A sensor giving its n-th read the value recorded for the n-th read."""

    def __init__(self, reads: Sequence[tuple[int, SensorValue]]) -> None:
        self._changes = deque(reads)
        self._value: SensorValue = None
        self._reads = 0

    def _next(self) -> SensorValue:
        while self._changes and self._changes[0][0] <= self._reads:
            self._value = self._changes.popleft()[1]
        self._reads += 1
        return self._value


class ReplayAnalogInput(_ReadOrder):
    """A brake-pressure or steering-angle sensor, replayed in read order."""

    def read(self) -> float | None:
        value = self._next()
        return None if isinstance(value, tuple) else value


class ReplayWheelSpeeds(_ReadOrder):
    """The wheel-speed sensor, replayed in read order."""

    def read(self) -> tuple[float, float] | None:
        value = self._next()
        return value if isinstance(value, tuple) else None


class ReplayDigitalIn(_ReadOrder):
    """The E-stop's line, replayed in read order (1.0 high)."""

    def get(self) -> bool:
        return self._next() == 1.0


def replay_hardware(record: RecordedRun, clock: VirtualClock) -> Hardware:
    """Ports that replay `record` on `clock`, with a wake-up at every recorded arrival."""
    for time_s in sorted({t for t, _, _ in record.rc_bytes} | {t for t, _ in record.can_rx}):
        clock.call_at(time_s, clock.notify_input)
    periods, reads, present = record.header.pwm_period_s, record.sensor_reads, record.header.sensors
    lines = {name: SimDigitalOut(clock, name) for name in OUTPUT_NAMES}

    def analog(name: str) -> ReplayAnalogInput | None:
        return ReplayAnalogInput(reads.get(name, [])) if name in present else None

    return Hardware(
        clock=clock,
        can=ReplayCanPort(
            clock, record.can_rx, record.refusals.get("can_tx", set()), record.links.get("can", ())
        ),
        rc_uart=ReplayByteStream(clock, record.rc_bytes, record.links.get("rc_uart", ())),
        dac=ReplayDac(
            SimDac6574(clock),
            record.refusals.get("dac", set()),
            stalls=(clock, record.stalls.get("dac", {})),
        ),
        steering_pwm=SimPwmChannel(clock, periods["steering"], "steering"),
        hydrobrake_pwm=SimPwmChannel(clock, periods["hydrobrake"], "hydrobrake"),
        outputs=DigitalOutputs.of(lines),
        wheel_speeds=ReplayWheelSpeeds(reads.get("wheel_speeds", []))
        if "wheel_speeds" in present
        else None,
        hydrobrake_pressure_bar=analog("hydrobrake_pressure_bar"),
        steering_encoder_norm=analog("steering_encoder_norm"),
        estop_line=ReplayDigitalIn(reads.get("estop_line", []))
        if "estop_line" in present
        else None,
    )
