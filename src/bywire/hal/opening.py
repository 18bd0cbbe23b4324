"""The one chooser: a robot's configuration in, its `Hardware` out, de-energised on the way out.

`open_hardware(config)` is a context manager. `backend = "linux"` opens the Linux backends in
the order that keeps the robot safe while it happens: the GPIO lines first (requested low: motors
disabled, e-brake engaged), then the DAC (0 V), the PWM outputs (enabled at duty 0), and the
inputs last. `backend = "sim"` builds the simulated robot on a real-time clock, at rest: the RC
transmitter idle in STOP, the higher-level computer sending neutral commands (scenarios are
`bywire sim`'s job; this is a dry run of `bywire run` on any machine). On exit every output is
de-energised (every line low, 0 V on the DAC, no PWM pulse) before the devices are closed, and
every close is tried even if one fails.

Absolute paths in the configuration are used as given; names resolve under `LinuxPaths`, whose
roots a container or a test can move (`bywire run --sysfs-root/--dev-root`).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, fields
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeVar

from bywire.config import RobotConfig, output_lines
from bywire.config.dac_backends import dac_backend
from bywire.config.tree import OUTPUT_LINE_KEYS, DacOutput, PwmOutput
from bywire.errors import HardwareError
from bywire.hal.hardware import DigitalOutputs, Hardware
from bywire.hal.ports import ByteStream, CanPort, I2cDevice, PwmChannel

if TYPE_CHECKING:
    from bywire.hal.linux.clock import LinuxClock
    from bywire.hal.linux.gpio_gpiod import GpiodOutputs
from bywire.protocol import dac6574

log = logging.getLogger(__name__)
T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class LinuxPaths:
    """Where the kernel's sysfs and device files are (moved by containers and tests)."""

    sysfs_root: Path = Path("/sys")
    dev_root: Path = Path("/dev")

    def device(self, name: str) -> str:
        """`name` if it is a path, else the device file of that name under `dev_root`."""
        return name if Path(name).is_absolute() else str(self.dev_root / name)


@contextlib.contextmanager
def open_hardware(config: RobotConfig, paths: LinuxPaths | None = None) -> Iterator[Hardware]:
    """The robot's ports; on exit (normal, error or signal) outputs de-energised, then closed."""
    opener = _open_sim if config.backend == "sim" else _open_linux
    with contextlib.ExitStack() as stack:
        hardware = opener(config, paths or LinuxPaths(), stack)
        stack.callback(de_energise, hardware, config.drive.dac)
        yield hardware


def de_energise(hardware: Hardware, dac: DacOutput) -> None:
    """Every line low, 0 V on both DAC outputs, no PWM pulse; each tried whatever fails."""
    for output in hardware.outputs.named().values():
        _try(output.set, False)
    for channel in (dac.throttle_channel, dac.regen_channel):
        _try(hardware.dac.write, dac6574.encode_write(channel, 0))
    for pwm in (hardware.steering_pwm, hardware.hydrobrake_pwm):
        _try(pwm.set_pulse, 0.0)


def _try(action: Callable[[T], None], value: T) -> None:
    try:
        action(value)
    except HardwareError as error:
        log.warning("de-energising: %s", error)


def _open_sim(config: RobotConfig, _paths: LinuxPaths, stack: contextlib.ExitStack) -> Hardware:
    from bywire.hal.simulated.clock import RealtimeClock  # noqa: PLC0415 -- only the chosen backend
    from bywire.hal.simulated.world import SimWorld  # noqa: PLC0415

    world = SimWorld.from_robot(RealtimeClock(), config)
    world.start()
    stack.callback(world.stop)
    return world.hardware


ESTOP_INPUT = "estop"
"""The E-stop's input among the GPIO device's lines (`[estop] line`, opened with the outputs)."""

Opener = Callable[[contextlib.ExitStack], T]
"""Opens one device and puts its close on the stack; HardwareError says what is wrong."""


class Device(StrEnum):
    """Every device the Linux backend opens, by what the user calls it (`bywire run --check`)."""

    GPIO = "GPIO output lines"
    DAC = "DAC"
    STEERING_PWM = "steering PWM"
    HYDROBRAKE_PWM = "hydraulic brake PWM"
    RC_UART = "RC receiver (UART)"
    CAN = "CAN bus"


@dataclass(frozen=True, slots=True)
class LinuxOpeners:
    """Each device's opener, typed by what it opens, in the order that keeps the robot safe while
    they open (outputs low first, inputs last): the fields' order is the opening order."""

    gpio: Opener[GpiodOutputs]
    dac: Opener[I2cDevice]
    steering_pwm: Opener[PwmChannel]
    hydrobrake_pwm: Opener[PwmChannel]
    rc_uart: Opener[ByteStream]
    can: Opener[CanPort]

    def in_order(self) -> list[tuple[Device, Opener[object]]]:
        """(device, opener) for each field, in the opening order."""
        return [(Device[field.name.upper()], getattr(self, field.name)) for field in fields(self)]


def linux_openers(config: RobotConfig, paths: LinuxPaths, clock: LinuxClock) -> LinuxOpeners:
    """Every device the configuration names (see `LinuxOpeners`)."""
    from bywire.hal.linux.can_open import BusSettings  # noqa: PLC0415 -- only the chosen backend
    from bywire.hal.linux.can_pythoncan import PythonCanPort  # noqa: PLC0415
    from bywire.hal.linux.clock import LinuxClock  # noqa: PLC0415
    from bywire.hal.linux.gpio_gpiod import GpiodOutputs, LineSpec  # noqa: PLC0415
    from bywire.hal.linux.pwm_sysfs import SysfsPwm, find_pwm_chip  # noqa: PLC0415
    from bywire.hal.linux.serial_pyserial import PyserialStream  # noqa: PLC0415
    from bywire.protocol import dbc  # noqa: PLC0415

    assert isinstance(clock, LinuxClock)
    specs = {
        name: LineSpec(OUTPUT_LINE_KEYS[name], line.chip, line.line)
        for name, line in output_lines(config).items()
    }

    estop = config.estop.line
    inputs = {} if estop is None else {ESTOP_INPUT: LineSpec("estop.line", estop.chip, estop.line)}

    def gpio(stack: contextlib.ExitStack) -> GpiodOutputs:
        lines = GpiodOutputs(specs, paths.dev_root, inputs)
        stack.callback(lines.close)
        return lines

    def pwm(key: str, output: PwmOutput) -> Opener[PwmChannel]:
        def open_pwm(stack: contextlib.ExitStack) -> PwmChannel:
            chip = find_pwm_chip(paths.sysfs_root, output.chip)
            opened = SysfsPwm(chip, output.channel, 1.0 / output.frequency_hz, key)
            stack.callback(opened.close)
            return opened

        return open_pwm

    def rc(stack: contextlib.ExitStack) -> ByteStream:
        port = PyserialStream(
            paths.device(config.rc.port), clock.notify_input, baud=config.rc.baud, now_s=clock.now
        )
        stack.callback(port.close)
        return port

    def can(stack: contextlib.ExitStack) -> CanPort:
        section = config.can
        settings = BusSettings(
            section.interface,
            section.channel,
            section.bitrate_bps,
            accept_ids=dbc.received_ids(),
            sample_point=section.sample_point,
            clock_hz=section.clock_hz,
            sysfs_root=paths.sysfs_root,
        )
        port = PythonCanPort(settings, clock.notify_input, clock.now)
        stack.callback(port.close)
        return port

    return LinuxOpeners(
        gpio=gpio,
        dac=lambda stack: _open_dac(config.drive.dac, paths, stack),
        steering_pwm=pwm("steering.pwm", config.steering.pwm),
        hydrobrake_pwm=pwm("hydrobrake.pwm", config.hydrobrake.pwm),
        rc_uart=rc,
        can=can,
    )


def _open_linux(config: RobotConfig, paths: LinuxPaths, stack: contextlib.ExitStack) -> Hardware:
    from bywire.hal.linux.clock import LinuxClock  # noqa: PLC0415 -- only the chosen backend

    clock = LinuxClock()
    openers = linux_openers(config, paths, clock)
    in_order = openers.in_order()
    devices = [device for device, _ in in_order]

    def opened(device: Device, opener: Opener[T]) -> T:
        try:
            return opener(stack)
        except HardwareError as error:
            # Like a pre-arm check: every other device's problem too, not one per attempt.
            later = [other for _, other in in_order[devices.index(device) + 1 :]]
            problems = [str(error), *_problems(later)]
            raise HardwareError("\n".join(dict.fromkeys(problems))) from error  # once each

    gpio = opened(Device.GPIO, openers.gpio)
    dac = opened(Device.DAC, openers.dac)
    steering_pwm = opened(Device.STEERING_PWM, openers.steering_pwm)
    hydrobrake_pwm = opened(Device.HYDROBRAKE_PWM, openers.hydrobrake_pwm)
    rc_uart = opened(Device.RC_UART, openers.rc_uart)
    can = opened(Device.CAN, openers.can)
    outputs = DigitalOutputs.of(gpio.lines)
    estop = gpio.inputs.get(ESTOP_INPUT)
    return Hardware(
        clock, can, rc_uart, dac, steering_pwm, hydrobrake_pwm, outputs, estop_line=estop
    )


def _problems(openers: Sequence[Opener[object]]) -> list[str]:
    """What is wrong with each device, each opened alone and closed again."""
    problems = []
    for opener in openers:
        try:
            with contextlib.ExitStack() as stack:
                opener(stack)
        except HardwareError as error:
            problems.append(str(error))
    return problems


def preflight(config: RobotConfig, paths: LinuxPaths | None = None) -> list[tuple[str, str | None]]:
    """Every device the configuration names: (name, None) when it opens, (name, the problem)
    when it does not; each opened alone and closed again (outputs never energised)."""
    if config.backend == "sim":
        return [("simulated robot", None)]
    from bywire.hal.linux.clock import LinuxClock  # noqa: PLC0415 -- only the chosen backend

    results: list[tuple[str, str | None]] = []
    for device, opener in linux_openers(config, paths or LinuxPaths(), LinuxClock()).in_order():
        problems = _problems([opener])
        results.append((device.value, problems[0] if problems else None))
    return results


def _open_dac(dac: DacOutput, paths: LinuxPaths, stack: contextlib.ExitStack) -> I2cDevice:
    """The backend the robot file names (`[drive.dac] backend`), by its row's opener."""
    row = dac_backend(dac.backend)
    opener: DacOpener = importlib.import_module(row.module).open_dac
    try:
        return opener(dac, paths, stack)
    except HardwareError as error:
        raise HardwareError(f"{error} (DAC backend {row.name!r} needs {row.needs})") from error


class DacOpener(Protocol):
    """What every `DAC_BACKENDS` row's module offers as `open_dac`."""

    def __call__(
        self, dac: DacOutput, paths: LinuxPaths, stack: contextlib.ExitStack, /
    ) -> I2cDevice: ...
