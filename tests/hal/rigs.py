"""One test rig per backend: the ports, a way to feed their inputs, and read-back of their outputs.

The simulated rig reads the simulated devices; the Linux rigs open the real backends through
`open_hardware` on the stand-ins of `tests.hal.linux` and read what they wrote there. The tape
backend has two rigs: the simulated ports under taped ports (read back from the simulated devices,
each read-back and each close also checking that the tape holds what crossed), and the playback
ports as `bywire replay` runs the controller on them (read back from the tape it compares).

A conformance test that cannot apply to a backend is named in its rig's `NOT_APPLICABLE`, with
the reason; the suite then does not generate it for that backend (nothing is skipped silently).
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import can
import pytest

from bywire.can_frame import CanFrame
from bywire.config import DacOutput, RobotConfig, output_lines, parse_config
from bywire.errors import HardwareError
from bywire.hal.hardware import Hardware
from bywire.hal.linux import dac_smbus2, gpio_gpiod
from bywire.hal.opening import LinuxPaths, de_energise, open_hardware
from bywire.hal.ports import LINK_UP, ByteStream, CanPort, I2cDevice, LinkState
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.hal.tape.playback import replay_hardware
from bywire.hal.tape.run_record import Event, RecordedRun, RecordHeader, link_of
from bywire.hal.tape.taped import Tape, taped_hardware
from bywire.protocol import dac6574
from tests.hal.linux import bench as fake_bench
from tests.hal.linux import fake_gpiod
from tests.hal.linux.bench import Bench, make_bench
from tests.hal.linux.fake_smbus import RecordingSMBus
from tests.hal.linux.fake_sysfs import pwm_core_checks
from tests.hal.linux.pty_rc import PtyRcLine
from tests.kernel import guest

SETTLE_S = 0.01
PWM_NAMES = {"steering": "steering_pwm", "hydrobrake": "hydrobrake_pwm"}
_CAN_OFF_THE_BUS = "test_a_can_port_off_the_bus_says_so_and_frames_arrive_once_it_is_back"
_RC_LINE_LOST = "test_a_lost_rc_line_says_so_and_bytes_arrive_once_it_is_back"


class SimRig:
    """The simulated robot's ports on virtual time; a second node on its bus is the peer."""

    NOT_APPLICABLE: ClassVar[Mapping[str, str]] = {}

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
        self.peer.send(CanFrame(frame_id, data))

    def peer_frames(self) -> list[tuple[int, bytes]]:
        return [(frame.arbitration_id, frame.data) for frame in self.peer.receive()]

    def lose_rc_line(self) -> None:
        self.world.uart.fail()

    def restore_rc_line(self) -> None:
        self.world.uart.restore()

    def take_can_off_bus(self) -> None:
        self.world.controller_can.enter_bus_off()

    def put_can_back(self) -> None:
        self.world.controller_can.recover_bus_off()

    def close(self) -> None:
        de_energise(self.hardware, DacOutput())


class LinuxRig:
    """The Linux backends through `open_hardware`, on a temporary sysfs, pty, virtual CAN."""

    NOT_APPLICABLE: ClassVar[Mapping[str, str]] = {
        _CAN_OFF_THE_BUS: (
            "python-can's virtual bus has no bus state and cannot be taken down: the unit tests"
            " of the python-can port pull its adapter instead, and the kernel rigs take vcan down"
        ),
    }

    def __init__(self, root: Path, monkeypatch: pytest.MonkeyPatch, dac: DacRig) -> None:
        monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
        pwm_core_checks(monkeypatch)
        self.smbus: list[RecordingSMBus] = []
        self._dac = dac
        if dac.smbus:
            monkeypatch.setattr(dac_smbus2, "KernelI2cBus", self._recording_bus)
        self.bench: Bench = make_bench(root, iio=not dac.smbus)
        self.line = PtyRcLine(self.bench.rc_link)
        text = self.bench.config_text().replace(
            "[drive.dac]\n", f'[drive.dac]\nbackend = "{dac.backend}"\n', 1
        )
        config = parse_config(text)
        assert config.drive.dac.backend == dac.backend, "the bench's robot file has no [drive.dac]"
        self._stack = contextlib.ExitStack()
        self._stack.callback(self.line.close)
        paths = LinuxPaths(self.bench.sysfs, self.bench.dev)
        self.hardware = self._stack.enter_context(open_hardware(config, paths))
        self.peer = can.Bus(interface="virtual", channel=self.bench.can_channel)
        self._stack.callback(self.peer.shutdown)

    def _recording_bus(self, path: str) -> RecordingSMBus:
        bus = RecordingSMBus(path, smbus_only=self._dac.smbus_only)
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
        if self._dac.read_back is not None:
            return self._dac.read_back(self.hardware.dac, channel)
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

    def lose_rc_line(self) -> None:
        self.line.unplug()

    def restore_rc_line(self) -> None:
        self.line.plug()

    def take_can_off_bus(self) -> None:
        raise AssertionError(self.NOT_APPLICABLE[_CAN_OFF_THE_BUS])

    def put_can_back(self) -> None:
        raise AssertionError(self.NOT_APPLICABLE[_CAN_OFF_THE_BUS])

    def close(self) -> None:
        self._stack.close()


def _noted(tape: Tape, name: str) -> list[tuple[float, object]]:
    """Every value the tape noted for output `name`, with its time."""
    return [(e["t"], e["value"]) for e in tape.events if e["kind"] == "out" and e["name"] == name]


def _last_noted(tape: Tape, name: str, default: object) -> object:
    noted = _noted(tape, name)
    return noted[-1][1] if noted else default


class _Witness:
    """What crossed the RC line, CAN port and DAC beneath the tape, counted apart from the tape."""

    def __init__(self, hardware: Hardware) -> None:
        self.rc = bytearray()
        self.received: list[CanFrame] = []
        self.sent: list[tuple[CanFrame, bool]] = []
        self.dac_writes: list[tuple[bytes, bool]] = []
        self.links: dict[str, list[tuple[float, LinkState]]] = {"can": [], "rc_uart": []}
        self.hardware = dataclasses.replace(
            hardware,
            rc_uart=_WitnessUart(hardware.rc_uart, self),
            can=_WitnessCan(hardware.can, self),
            dac=_WitnessDac(hardware.dac, self),
        )
        self._clock = hardware.clock

    def read_link(self, name: str, link: LinkState) -> LinkState:
        self.links[name].append((self._clock.now(), link))
        return link


class _WitnessUart:
    def __init__(self, inner: ByteStream, witness: _Witness) -> None:
        self._inner, self._witness = inner, witness

    def read_available(self) -> bytes:
        data = self._inner.read_available()
        self._witness.rc.extend(data)
        return data

    @property
    def arrived_at_s(self) -> float | None:
        return self._inner.arrived_at_s

    @property
    def link(self) -> LinkState:
        return self._witness.read_link("rc_uart", self._inner.link)


class _WitnessCan:
    def __init__(self, inner: CanPort, witness: _Witness) -> None:
        self._inner, self._witness = inner, witness

    def send(self, frame: CanFrame) -> bool:
        accepted = self._inner.send(frame)
        self._witness.sent.append((frame, accepted))
        return accepted

    def receive(self) -> list[CanFrame]:
        frames = self._inner.receive()
        self._witness.received.extend(frames)
        return frames

    @property
    def link(self) -> LinkState:
        return self._witness.read_link("can", self._inner.link)


class _WitnessDac:
    def __init__(self, inner: I2cDevice, witness: _Witness) -> None:
        self._inner, self._witness = inner, witness

    def write(self, data: bytes) -> None:
        try:
            self._inner.write(data)
        except HardwareError:
            self._witness.dac_writes.append((data, False))
            raise
        self._witness.dac_writes.append((data, True))


class TapedSimRig(SimRig):
    """The simulated ports under taped ports: every promise of the simulated backend, through the
    tape, and the tape holding what crossed.

    Read-backs come from the simulated devices (the far side). Every read-back, every settle and
    closing also check the whole tape (`check_tape`): each line's and pulse's changes at their
    times as the simulated devices saw them, and, against a witness beneath the tape, the RC bytes
    and CAN frames received, the frames sent and refused, the DAC frames written and refused.
    """

    def __init__(self) -> None:
        super().__init__()
        self.tape = Tape(self.clock)
        self.witness = _Witness(self.world.hardware)
        self.hardware = taped_hardware(self.witness.hardware, self.tape)

    def settle(self) -> None:
        super().settle()
        self.check_tape()

    def level(self, name: str) -> bool:
        self.check_tape()
        return super().level(name)

    def pulse_s(self, name: str) -> float:
        self.check_tape()
        return super().pulse_s(name)

    def dac_code(self, channel: int) -> int:
        self.check_tape()
        return super().dac_code(channel)

    def peer_frames(self) -> list[tuple[int, bytes]]:
        self.check_tape()
        return super().peer_frames()

    def close(self) -> None:
        super().close()
        self.check_tape()

    def check_tape(self) -> None:
        """AssertionError unless the tape holds exactly what crossed the ports beneath it."""
        events, witness = self.tape.events, self.witness
        for name, line in self.world.gpio.items():
            noted = _noted(self.tape, f"gpio.{name}")
            assert noted == line.history, f"tape: {name} {noted}, the line: {line.history}"
        for name, channel in (
            ("steering", self.world.pwm.steering),
            ("hydrobrake", self.world.pwm.hydrobrake),
        ):
            noted = _noted(self.tape, PWM_NAMES[name])
            assert noted == channel.history, f"tape: {name} {noted}, the PWM: {channel.history}"
        rc = b"".join(bytes.fromhex(e["hex"]) for e in events if e["kind"] == "rc_bytes")
        assert rc == witness.rc, f"tape: RC bytes {rc.hex()}, read: {witness.rc.hex()}"
        received = [
            CanFrame(frame_id, bytes.fromhex(data), stamp_s)
            for e in events
            if e["kind"] == "can_rx"
            for frame_id, data, stamp_s in e["frames"]
        ]
        assert received == witness.received, f"tape: {received}, received: {witness.received}"
        sent = [(n, v) for _, n, v in _outs(events) if n.startswith("can_tx.")]
        expected = [(f"can_tx.0x{f.arbitration_id:03X}", f.data.hex()) for f, _ in witness.sent]
        assert sent == expected, f"tape: sent {sent}, sent: {expected}"
        assert _refused(events, "can_tx") == [i for i, (_, ok) in enumerate(witness.sent) if not ok]
        assert _refused(events, "dac") == [
            i for i, (_, ok) in enumerate(witness.dac_writes) if not ok
        ]
        dac = [(n, v) for _, n, v in _outs(events) if n.startswith("dac")]
        written = _changes(
            (f"dac.{dac6574.decode_frame(data).channel}", data.hex())
            for data, ok in witness.dac_writes
            if ok
        )
        assert dac == written, f"tape: DAC {dac}, written: {written}"
        for name, reads in witness.links.items():
            noted = [
                (e["t"], link_of(e)) for e in events if e["kind"] == "link" and e["name"] == name
            ]
            changes, last = [], LINK_UP
            for time_s, link in reads:
                if link != last:
                    changes.append((time_s, link))
                    last = link
            assert noted == changes, f"tape: {name} links {noted}, read: {changes}"


def _outs(events: list[Event]) -> list[tuple[float, str, object]]:
    return [(e["t"], str(e["name"]), e["value"]) for e in events if e["kind"] == "out"]


def _refused(events: list[Event], name: str) -> list[int]:
    return [e["call"] for e in events if e["kind"] == "refused" and e["name"] == name]


def _changes(writes: Iterable[tuple[str, str]]) -> list[tuple[str, str]]:
    """Each name's first value and every change of it, in write order."""
    last: dict[str, str] = {}
    changes = []
    for name, value in writes:
        if last.get(name) != value:
            changes.append((name, value))
            last[name] = value
    return changes


PLAYBACK_HEADER = RecordHeader(
    "conformance", 0.0, 0.0, {"steering": 0.020, "hydrobrake": 0.001}, (), ""
)


class PlaybackRig:
    """The playback ports as `bywire replay` runs the controller on them: under taped ports.

    A record's inputs are known before a replay starts; the conformance tests feed theirs as they
    go. So each feed is a record of its own, arriving at the instant it is fed and played by a
    playback bundle of its own (`replay_hardware`, which also schedules its wake-up); the rig's RC
    line and CAN port hand up, in feeding order, what those bundles' ports give. Everything else
    (outputs, sends, refusals) is the first bundle's. What was written is read back from the tape,
    as `bywire replay` compares it with the record; a sent frame reaches no other node, it is kept.
    """

    NOT_APPLICABLE: ClassVar[Mapping[str, str]] = {
        "test_command_frames_arrive_and_other_ids_are_filtered": (
            "a record holds the frames the controller received, after the recording port's"
            " filter: playback hands back exactly those and has no filter of its own to test"
        ),
    }

    def __init__(self) -> None:
        self.clock = VirtualClock()
        self.tape = Tape(self.clock)
        self._fed: list[Hardware] = []
        self._links: dict[str, Hardware] = {}
        played = replay_hardware(RecordedRun(PLAYBACK_HEADER), self.clock)
        fed = dataclasses.replace(
            played,
            rc_uart=_FedUart(self._fed, self._links),
            can=_FedCan(played.can, self._fed, self._links),
        )
        self.hardware = taped_hardware(fed, self.tape)
        self._sends_seen = 0

    def _feed(self, record: RecordedRun) -> None:
        self._fed.append(replay_hardware(record, self.clock))

    def settle(self) -> None:
        self.clock.advance(SETTLE_S)

    def level(self, name: str) -> bool:
        return bool(_last_noted(self.tape, f"gpio.{name}", False))

    def pulse_s(self, name: str) -> float:
        pulse_s = _last_noted(self.tape, PWM_NAMES[name], 0.0)
        assert isinstance(pulse_s, float)
        return pulse_s

    def dac_code(self, channel: int) -> int:
        frame = _last_noted(self.tape, f"dac.{channel}", None)
        return 0 if frame is None else dac6574.decode_write(bytes.fromhex(str(frame)))[1]

    def feed_rc(self, data: bytes) -> None:
        now_s = self.clock.now()
        self._feed(RecordedRun(PLAYBACK_HEADER, rc_bytes=[(now_s, data, now_s)]))

    def peer_send(self, frame_id: int, data: bytes) -> None:
        now_s = self.clock.now()
        self._feed(
            RecordedRun(PLAYBACK_HEADER, can_rx=[(now_s, [CanFrame(frame_id, data, now_s)])])
        )

    def peer_frames(self) -> list[tuple[int, bytes]]:
        sent = [(n, str(v)) for _, n, v in _outs(self.tape.events) if n.startswith("can_tx.")]
        new, self._sends_seen = sent[self._sends_seen :], len(sent)
        return [(int(name.removeprefix("can_tx."), 16), bytes.fromhex(data)) for name, data in new]

    def _feed_link(self, name: str, link: LinkState) -> None:
        """A record of its own in which port `name`'s link changes now (the newest one rules)."""
        record = RecordedRun(PLAYBACK_HEADER, links={name: [(self.clock.now(), link)]})
        self._links[name] = replay_hardware(record, self.clock)

    def lose_rc_line(self) -> None:
        self._feed_link("rc_uart", LinkState(down=True, receive_failures=1))

    def restore_rc_line(self) -> None:
        self._feed_link("rc_uart", LinkState(receive_failures=1))

    def take_can_off_bus(self) -> None:
        self._feed_link("can", LinkState(down=True))

    def put_can_back(self) -> None:
        self._feed_link("can", LINK_UP)

    def close(self) -> None:
        de_energise(self.hardware, DacOutput())


class _FedUart:
    def __init__(self, fed: list[Hardware], links: dict[str, Hardware]) -> None:
        self._fed, self._links = fed, links

    def read_available(self) -> bytes:
        return b"".join(hardware.rc_uart.read_available() for hardware in self._fed)

    @property
    def arrived_at_s(self) -> float | None:
        stamps = [hardware.rc_uart.arrived_at_s for hardware in self._fed]
        return max((stamp for stamp in stamps if stamp is not None), default=None)

    @property
    def link(self) -> LinkState:
        fed = self._links.get("rc_uart")
        return LINK_UP if fed is None else fed.rc_uart.link


class _FedCan:
    def __init__(self, played: CanPort, fed: list[Hardware], links: dict[str, Hardware]) -> None:
        self._played, self._fed, self._links = played, fed, links

    def send(self, frame: CanFrame) -> bool:
        return self._played.send(frame)

    def receive(self) -> list[CanFrame]:
        return [frame for hardware in self._fed for frame in hardware.can.receive()]

    @property
    def link(self) -> LinkState:
        fed = self._links.get("can")
        return LINK_UP if fed is None else fed.can.link


class KernelRig:
    """The Linux backends through `open_hardware` on a real kernel's devices (tests/kernel/run):
    gpio-sim lines, the PWM simulator behind the kernel's PWM core, a DAC on i2c-dev (plain I2C,
    SMBus only, or through the kernel's ti-dac5571), the RC receiver on a kernel tty fed from
    the host, and a vcan interface. Everything is read back from the kernel. Outside the guest
    kernel the rig skips with one line saying how to run it."""

    NOT_APPLICABLE: ClassVar[Mapping[str, str]] = {
        _RC_LINE_LOST: (
            "the host closes a guest's RC line for good (end of file), and every kernel rig shares"
            " this one: tests/kernel/test_faults.py closes a line of its own under `bywire run`"
        ),
    }
    DACS = ("plain-i2c", "smbus-only", "iio")

    def __init__(self, dac: str) -> None:
        if not guest.in_tier():
            pytest.skip(guest.SKIP_REASON)
        self._stack = contextlib.ExitStack()
        self._devices = contextlib.ExitStack()
        try:
            self._make_devices(dac)
            config = parse_config(guest.robot_config(self.vcan.name, self.dac.bus))
            self.hardware = self._stack.enter_context(open_hardware(config, LinuxPaths()))
            self.peer = can.Bus(interface="socketcan", channel=self.vcan.name)
            self._stack.callback(self.peer.shutdown)
        except BaseException:
            self._stack.close()
            self._devices.close()
            raise
        _KERNEL_DEVICES.append(self._devices)

    def _make_devices(self, dac: str) -> None:
        while _KERNEL_DEVICES:  # the last rig's devices, kept for read-back after its close
            _KERNEL_DEVICES.pop().close()
        self.vcan = guest.Vcan()
        self._devices.callback(self.vcan.close)
        self.gpio = guest.GpioSim(fake_bench.GPIO_LABEL, fake_bench.line_names())
        self._devices.callback(self.gpio.close)
        self.pwm_chip = guest.pwm_sim()
        self.dac: guest.I2cStub | guest.I2cSim = (
            guest.I2cStub() if dac == "smbus-only" else guest.I2cSim()
        )
        self._devices.callback(self.dac.close)
        if dac == "iio":
            assert isinstance(self.dac, guest.I2cSim)
            self.dac.bind_driver()
        self.host = guest.HostLine()
        self.host.drain()
        self._devices.callback(self.host.close)

    def settle(self) -> None:
        self.hardware.clock.wait_until(self.hardware.clock.now() + SETTLE_S)

    def level(self, name: str) -> bool:
        line = output_lines(RobotConfig())[name].line
        return self.gpio.level(str(line))

    def pulse_s(self, name: str) -> float:
        _, duty_ns, enabled = guest.pwm_applied(0 if name == "steering" else 1)
        return duty_ns / 1e9 if enabled else 0.0

    def dac_code(self, channel: int) -> int:
        return self.dac.code(channel)

    def feed_rc(self, data: bytes) -> None:
        self.host.send_rc(data)

    def peer_send(self, frame_id: int, data: bytes) -> None:
        self.peer.send(can.Message(arbitration_id=frame_id, data=data, is_extended_id=False))

    def peer_frames(self) -> list[tuple[int, bytes]]:
        frames = []
        while (message := self.peer.recv(0.05)) is not None:
            frames.append((message.arbitration_id, bytes(message.data)))
        return frames

    def lose_rc_line(self) -> None:
        raise AssertionError(self.NOT_APPLICABLE[_RC_LINE_LOST])

    def restore_rc_line(self) -> None:
        raise AssertionError(self.NOT_APPLICABLE[_RC_LINE_LOST])

    def take_can_off_bus(self) -> None:
        self.vcan.set_up(False)

    def put_can_back(self) -> None:
        self.vcan.set_up(True)
        # The peer's socket holds the interface's going down as an error its next send would
        # raise (ENETDOWN): the peer is a node of its own, plugged in again.
        self.peer.shutdown()
        self.peer = can.Bus(interface="socketcan", channel=self.vcan.name)
        self._stack.callback(self.peer.shutdown)

    def close(self) -> None:
        self._stack.close()


_KERNEL_DEVICES: list[contextlib.ExitStack] = []


@dataclass(frozen=True, slots=True)
class DacRig:
    """A Linux rig for one `DAC_BACKENDS` row: the bench it runs on, and how it reads back."""

    backend: str  # the row's name, written into the bench's `[drive.dac] backend`
    smbus: bool = False  # a bench without the IIO driver, the i2c-dev writes recorded
    smbus_only: bool = False  # ... by an adapter that does SMBus transfers only
    read_back: Callable[[I2cDevice, int], int] | None = None  # else from the bench


DAC_RIGS: dict[str, DacRig] = {
    "linux-iio": DacRig("auto"),
    "linux-smbus2": DacRig("auto", smbus=True),
    "linux-smbus-only": DacRig("auto", smbus=True, smbus_only=True),
}
"""Every DAC backend's conformance rigs (each row of `DAC_BACKENDS` has one at least)."""

Rig = SimRig | LinuxRig | PlaybackRig | KernelRig
RIGS: dict[str, type[Rig]] = {
    "sim": SimRig,
    **dict.fromkeys(DAC_RIGS, LinuxRig),
    "sim-taped": TapedSimRig,
    "playback": PlaybackRig,
    **{f"kernel-{dac}": KernelRig for dac in KernelRig.DACS},
}
BACKENDS = tuple(RIGS)


def make_rig(backend: str, root: Path, monkeypatch: pytest.MonkeyPatch) -> Rig:
    if backend == "sim":
        return SimRig()
    if backend == "sim-taped":
        return TapedSimRig()
    if backend == "playback":
        return PlaybackRig()
    if backend.startswith("kernel-"):
        return KernelRig(backend.removeprefix("kernel-"))
    return LinuxRig(root, monkeypatch, DAC_RIGS[backend])


def not_applicable(backend: str) -> Mapping[str, str]:
    """The conformance tests that cannot apply to `backend`'s rig, each with the reason."""
    return RIGS[backend].NOT_APPLICABLE


def settle_until(rig: Rig, condition: Callable[[], bool], *, attempts: int = 500) -> bool:
    """Let the rig run until `condition` holds (at most `attempts` short waits)."""
    for _ in range(attempts):
        if condition():
            return True
        rig.settle()
    return condition()
