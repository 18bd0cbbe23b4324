"""Taped ports: wrappers around a Hardware bundle that note every input and output on a tape.

They sit exactly on the seam (`bywire.hal.ports`), so a tape holds everything the controller
received and everything it wrote, whatever the backend; `bywire.hal.tape.run_record` describes the
events. The wrappers only forward and note: the controller cannot tell them from the ports.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

from bywire.can_frame import CanFrame
from bywire.errors import FrameError, HardwareError
from bywire.hal.hardware import DigitalOutputs, Hardware
from bywire.hal.ports import (
    LINK_UP,
    ByteStream,
    CanPort,
    Clock,
    DigitalIn,
    DigitalOut,
    I2cDevice,
    LinkState,
    PwmChannel,
)
from bywire.hal.tape.run_record import Event, OutputValue, link_event
from bywire.protocol import dac6574

V = TypeVar("V")
_UNSET = object()


class Tape:
    """Events in the order they happened, stamped with the clock's time."""

    def __init__(self, clock: Clock) -> None:
        self._clock = clock
        self.events: list[Event] = []
        self._last_output: dict[str, OutputValue] = {}

    def now(self) -> float:
        return self._clock.now()

    def add(self, kind: str, **values: object) -> None:
        self.events.append({"t": self._clock.now(), "kind": kind, **values})

    def output(self, name: str, value: OutputValue, *, on_change: bool = True) -> None:
        """Note an output; with `on_change`, only its first value and every change."""
        if on_change and self._last_output.get(name, _UNSET) == value:
            return
        self._last_output[name] = value
        self.add("out", name=name, value=value)


class _LinkNotes:
    """Notes a port's `LinkState` each time a read of it differs from the read before."""

    def __init__(self, name: str, tape: Tape) -> None:
        self._name, self._tape = name, tape
        self._last = LINK_UP

    def seen(self, link: LinkState) -> LinkState:
        if link is not self._last and link != self._last:
            self._last = link
            self._tape.add("link", **link_event(self._name, link))
        return link


class TapedByteStream:
    """A ByteStream noting each non-empty read, and each change of its link."""

    def __init__(self, inner: ByteStream, tape: Tape) -> None:
        self._inner, self._tape = inner, tape
        self._link = _LinkNotes("rc_uart", tape)

    def read_available(self) -> bytes:
        data = self._inner.read_available()
        if data:
            arrived_at_s = self._inner.arrived_at_s
            stamp = {} if arrived_at_s is None else {"at": arrived_at_s}
            self._tape.add("rc_bytes", hex=data.hex(), **stamp)
        return data

    @property
    def arrived_at_s(self) -> float | None:
        return self._inner.arrived_at_s

    @property
    def link(self) -> LinkState:
        return self._link.seen(self._inner.link)


class TapedCanPort:
    """A CanPort noting each non-empty receive, every frame sent and every refused send, and
    each change of its link."""

    def __init__(self, inner: CanPort, tape: Tape) -> None:
        self._inner, self._tape = inner, tape
        self._sends = 0
        self._link = _LinkNotes("can", tape)

    def send(self, frame: CanFrame) -> bool:
        call, self._sends = self._sends, self._sends + 1
        accepted = self._inner.send(frame)
        self._tape.output(f"can_tx.0x{frame.arbitration_id:03X}", frame.data.hex(), on_change=False)
        if not accepted:
            self._tape.add("refused", name="can_tx", call=call)
        return accepted

    def receive(self) -> list[CanFrame]:
        frames = self._inner.receive()
        if frames:
            rows = [[f.arbitration_id, f.data.hex(), f.timestamp_s] for f in frames]
            self._tape.add("can_rx", frames=rows)
        return frames

    @property
    def link(self) -> LinkState:
        return self._link.seen(self._inner.link)


class TapedDac:
    """An I2cDevice (the DAC6574) noting each channel's frame when it changes, and each NAK."""

    def __init__(self, inner: I2cDevice, tape: Tape) -> None:
        self._inner, self._tape = inner, tape
        self._writes = 0

    def write(self, data: bytes) -> None:
        call, self._writes = self._writes, self._writes + 1
        started_s = self._tape.now()
        try:
            self._inner.write(data)
        except HardwareError:
            self._note_stall(call, started_s)
            self._tape.add("refused", name="dac", call=call)
            raise
        self._note_stall(call, started_s)
        try:
            name = f"dac.{dac6574.decode_frame(data).channel}"
        except FrameError:
            name = "dac"  # a device that acknowledged a frame the codec cannot read: still noted
        self._tape.output(name, data.hex())

    def _note_stall(self, call: int, started_s: float) -> None:
        """A write that took simulated time (hung inside the driver): how long, so that replay
        lets the same time run inside the same write (what the watchdog saw meanwhile)."""
        stall_s = self._tape.now() - started_s
        if stall_s > 0.0:
            self._tape.add("stall", name="dac", call=call, s=stall_s)


class TapedPwm:
    """A PwmChannel noting its pulse width when it changes."""

    def __init__(self, inner: PwmChannel, name: str, tape: Tape) -> None:
        self._inner, self._name, self._tape = inner, name, tape

    @property
    def period_s(self) -> float:
        return self._inner.period_s

    def set_pulse(self, pulse_s: float) -> None:
        self._inner.set_pulse(pulse_s)
        self._tape.output(self._name, float(pulse_s))


class TapedDigitalOut:
    """A DigitalOut noting its level when it changes."""

    def __init__(self, inner: DigitalOut, name: str, tape: Tape) -> None:
        self._inner, self._name, self._tape = inner, name, tape

    def set(self, level: bool) -> None:
        self._inner.set(level)
        self._tape.output(self._name, bool(level))


class TapedSensor(Generic[V]):
    """A sensor noting the number of each read whose value differs from the read before."""

    def __init__(self, read: Callable[[], V], name: str, tape: Tape) -> None:
        self._read, self._name, self._tape = read, name, tape
        self._reads = 0
        self._last: object = _UNSET

    def read(self) -> V:
        value = self._read()
        if value != self._last:
            self._tape.add("sensor", name=self._name, read=self._reads, value=value)
            self._last = value
        self._reads += 1
        return value


class TapedDigitalIn:
    """A DigitalIn (the E-stop's line) noted as a sensor: 1.0 high, 0.0 low."""

    def __init__(self, inner: DigitalIn, name: str, tape: Tape) -> None:
        self._sensor = TapedSensor(lambda: 1.0 if inner.get() else 0.0, name, tape)

    def get(self) -> bool:
        return self._sensor.read() == 1.0


def taped_hardware(hardware: Hardware, tape: Tape) -> Hardware:
    """The same bundle with every port taped; the clock is shared, not taped."""
    outputs = hardware.outputs
    lines = {
        name: TapedDigitalOut(output, f"gpio.{name}", tape)
        for name, output in outputs.named().items()
    }
    wheels, pressure, encoder = (
        hardware.wheel_speeds,
        hardware.hydrobrake_pressure_bar,
        hardware.steering_encoder_norm,
    )
    return Hardware(
        clock=hardware.clock,
        can=TapedCanPort(hardware.can, tape),
        rc_uart=TapedByteStream(hardware.rc_uart, tape),
        dac=TapedDac(hardware.dac, tape),
        steering_pwm=TapedPwm(hardware.steering_pwm, "steering_pwm", tape),
        hydrobrake_pwm=TapedPwm(hardware.hydrobrake_pwm, "hydrobrake_pwm", tape),
        outputs=DigitalOutputs.of(lines),
        wheel_speeds=None if wheels is None else TapedSensor(wheels.read, "wheel_speeds", tape),
        hydrobrake_pressure_bar=None
        if pressure is None
        else TapedSensor(pressure.read, "hydrobrake_pressure_bar", tape),
        steering_encoder_norm=None
        if encoder is None
        else TapedSensor(encoder.read, "steering_encoder_norm", tape),
        estop_line=None
        if hardware.estop_line is None
        else TapedDigitalIn(hardware.estop_line, "estop_line", tape),
    )
