"""One test rig per backend: the ports, a way to feed their inputs, and read-back of their outputs.

The simulated rig reads the simulated devices; the Linux rigs open the real backends through
`open_hardware` on the stand-ins of `tests.hal.linux` and read what they wrote there.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path

import can
import pytest

from bywire.config import DacOutput, parse_config
from bywire.hal.hardware import Hardware
from bywire.hal.linux import dac_smbus2, gpio_gpiod
from bywire.hal.opening import LinuxPaths, de_energise, open_hardware
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.world import SimWorld
from bywire.protocol import dac6574
from tests.hal.linux import fake_gpiod
from tests.hal.linux.bench import Bench, make_bench
from tests.hal.linux.fake_smbus import RecordingSMBus
from tests.hal.linux.pty_rc import PtyRcLine

SETTLE_S = 0.01
BACKENDS = ("sim", "linux-iio", "linux-smbus2")


class SimRig:
    """The simulated robot's ports on virtual time; a second node on its bus is the peer."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        self.world = SimWorld.create(self.clock)
        self.hardware: Hardware = self.world.hardware
        self.peer = self.world.bus.attach("peer")

    def settle(self) -> None:
        self.clock.advance(SETTLE_S)

    def level(self, name: str) -> bool:
        return self.world.gpio[name].level

    def pulse_s(self, name: str) -> float:
        channel = self.world.pwm.steering if name == "steering" else self.world.pwm.hydrobrake
        return channel.pulse_s

    def dac_code(self, channel: int) -> int:
        return self.world.dac.code(channel)

    def feed_rc(self, data: bytes) -> None:
        self.world.uart.transmit(data)

    def peer_send(self, frame_id: int, data: bytes) -> None:
        from bywire.hal.ports import CanFrame  # noqa: PLC0415

        self.peer.send(CanFrame(frame_id, data))

    def peer_frames(self) -> list[tuple[int, bytes]]:
        return [(frame.arbitration_id, frame.data) for frame in self.peer.receive()]

    def close(self) -> None:
        de_energise(self.hardware, DacOutput())


class LinuxRig:
    """The Linux backends through `open_hardware`, on a temporary sysfs, pty, virtual CAN."""

    def __init__(self, root: Path, monkeypatch: pytest.MonkeyPatch, *, smbus: bool) -> None:
        monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
        self.smbus: list[RecordingSMBus] = []
        if smbus:
            monkeypatch.setattr(dac_smbus2, "SMBus", self._recording_bus)
        self.bench: Bench = make_bench(root, iio=not smbus)
        self.line = PtyRcLine(self.bench.rc_link)
        config = parse_config(self.bench.config_text())
        self._stack = contextlib.ExitStack()
        self._stack.callback(self.line.close)
        paths = LinuxPaths(self.bench.sysfs, self.bench.dev)
        self.hardware = self._stack.enter_context(open_hardware(config, paths))
        self.peer = can.Bus(interface="virtual", channel=self.bench.can_channel)
        self._stack.callback(self.peer.shutdown)

    def _recording_bus(self, path: str) -> RecordingSMBus:
        bus = RecordingSMBus(path)
        self.smbus.append(bus)
        return bus

    def settle(self) -> None:
        self.hardware.clock.wait_until(self.hardware.clock.now() + SETTLE_S)

    def level(self, name: str) -> bool:
        return bool(self.bench.levels()[name])

    def pulse_s(self, name: str) -> float:
        _, duty_ns, _ = self.bench.pwm(0 if name == "steering" else 1)
        return duty_ns / 1e9

    def dac_code(self, channel: int) -> int:
        if not self.smbus:
            return self.bench.dac_code(channel)
        codes = dict.fromkeys(dac6574.CHANNELS, 0)
        for _address, frame in self.smbus[0].transfers:
            written, code = dac6574.decode_write(frame)
            codes[written] = code
        return codes[channel]

    def feed_rc(self, data: bytes) -> None:
        self.line.write(data)

    def peer_send(self, frame_id: int, data: bytes) -> None:
        self.peer.send(can.Message(arbitration_id=frame_id, data=data, is_extended_id=False))

    def peer_frames(self) -> list[tuple[int, bytes]]:
        frames = []
        while (message := self.peer.recv(0)) is not None:
            frames.append((message.arbitration_id, bytes(message.data)))
        return frames

    def close(self) -> None:
        self._stack.close()


Rig = SimRig | LinuxRig


def make_rig(backend: str, root: Path, monkeypatch: pytest.MonkeyPatch) -> Rig:
    if backend == "sim":
        return SimRig()
    return LinuxRig(root, monkeypatch, smbus=backend == "linux-smbus2")


def settle_until(rig: Rig, condition: Callable[[], bool], *, attempts: int = 500) -> bool:
    """Let the rig run until `condition` holds (at most `attempts` short waits)."""
    for _ in range(attempts):
        if condition():
            return True
        rig.settle()
    return condition()
