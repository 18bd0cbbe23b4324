"""The kernel tier's devices, made and read inside the guest kernel (tests/kernel/run boots it).

Each helper makes one device with the kernel's own tools and drivers and reads back, from the
kernel, what the backend under test did to it:

- `Vcan`: a vcan network interface (module vcan; `ip link`), and qdiscs on it (`tc`);
- `GpioSim`: a gpio-sim chip made through configfs, its lines' levels from its sysfs;
- `pwm_sim()`: tests/kernel/modules/bywire_pwm_sim.ko behind the real PWM core, what the chip
  was told from its `applied` attribute;
- `I2cStub`: the kernel's i2c-stub (SMBus only), the bytes written read back from its registers;
- `I2cSim`: tests/kernel/modules/bywire_i2c_sim.ko (plain I2C), every message from `written`;
- `HostLine`: the serial line to the host (/dev/ttyS2), which puts bytes on the RC line
  (/dev/ttyS1) from outside, as the receiver's UART would.

Outside the guest nothing here is used: tests/kernel/conftest.py skips the tier with one line.
"""

from __future__ import annotations

import contextlib
import os
import select
import subprocess
import termios
import time
import tty
import uuid
from pathlib import Path

from smbus2 import SMBus

from bywire.protocol import dac6574
from tests.hal.linux.bench import GPIO_LABEL

SKIP_REASON = (
    "kernel tier: runs inside user-mode Linux: tests/kernel/run (README, 'The kernel tier')"
)
RC_TTY = "/dev/ttyS1"
RC_TTY_TO_CLOSE = "/dev/ttyS3"  # the RC line a test may close for good (the rest keep ttyS1)
CONTROL_TTY = "/dev/ttyS2"
DRAIN_LIMIT_S = 10.0
CONFIGFS_GPIO_SIM = Path("/sys/kernel/config/gpio-sim")
SYS_I2C = Path("/sys/bus/i2c/devices")
PWM_SIM_DEVICE = Path("/sys/devices/platform/bywire-pwm-sim.0")
DAC_ADDRESS = 0x4C


def in_tier() -> bool:
    """True inside the kernel tier's guest (tests/kernel/init.sh sets it)."""
    return os.environ.get("BYWIRE_KERNEL_TIER") == "1"


class ToolError(RuntimeError):
    """A tool run in the guest failed; the message says what it said."""


def run(*command: str) -> str:
    """Run a tool of the host's (ip, tc, insmod…) in the guest; its output, or ToolError with
    what it said."""
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise ToolError(f"{' '.join(command)}: {done.stderr.strip() or done.returncode}")
    return done.stdout


def robot_config(
    can_channel: str, i2c_bus: int, rc_tty: str = RC_TTY, estop_line: str = "none"
) -> str:
    """A robot file for the guest's devices: the GPIO chip labelled as the bench's, the PWM
    simulator's two channels, the DAC at its address on `i2c_bus`, the RC line on ttyS1.

    Its input timeouts and watchdog are 1 s and 3 s, not the robot's 0.1 s and 0.2 s: every
    system call of a guest process is a round trip through ptrace on the host, and bywire's
    passes, cheap on a board, overran by tens of milliseconds in the guest (about half of the
    100 Hz passes late with the guest 35 % idle), and stalled for 0.5 s at times on a loaded
    host, so the robot's own numbers judged the guest's speed, not the device paths.

    Since issue 29 every pass, port write and DAC transfer has a time budget, and overrunning
    it latches STOP (TIMING_FAULT; a slow transfer DAC_FAULT_STOP). The guest could not keep
    the robot's budgets: the robot never armed, or stopped while driving. So the budgets are
    the loader's largest (50 / 20 / 20 ms), which since issue 41 ask for the loosest stop
    promise a file may declare (`stop_response_s` 60 ms, not the robot's 10), the three
    fast tasks run at 50 Hz (the slowest issue 30's deadlines allow, which then ask for the
    tighter speed-step tolerance) and
    `bywire run` at SCHED_FIFO as on the robot (config/albert.toml), ahead of the tests'
    own processes in the guest. `estop_line`: the E-stop's line on the chip, or "none"."""
    return f"""name = "kernel-robot"
backend = "linux"
gpio_chip = "{GPIO_LABEL}"

[estop]
line = "{estop_line}"

[can]
interface = "socketcan"
channel = "{can_channel}"

[rc]
port = "{rc_tty}"

[steering.pwm]
chip = "bywire-pwm-sim.0"
channel = 0

[hydrobrake.pwm]
chip = "bywire-pwm-sim.0"
channel = 1

[drive.dac]
i2c_bus = {i2c_bus}
address = 0x{DAC_ADDRESS:02X}

[timeouts]
rc_timeout_s = 1.0
can_command_timeout_s = 1.0
watchdog_s = 3.0
stop_response_s = 0.06
pass_budget_s = 0.05
write_budget_s = 0.02
dac_transfer_budget_s = 0.02

[realtime]
scheduler = "fifo"

[tasks]
hydrobrake_rate_hz = 50.0
steering_rate_hz = 50.0
driving_rate_hz = 50.0

[interlocks]
speed_step_tolerance_mps = 0.2
"""


def loaded(module: str) -> bool:
    return Path("/sys/module", module.replace("-", "_")).is_dir()


def insmod(module: str, *parameters: str) -> None:
    """Load `module` (a tree module or one of tests/kernel/modules) if it is not loaded."""
    if not loaded(module):
        run("insmod", str(Path(os.environ["BYWIRE_MODULES"], f"{module}.ko")), *parameters)


def rmmod(module: str) -> None:
    if loaded(module):
        run("rmmod", module)


class Vcan:
    """A CAN interface of its own, up; `close` deletes it.

    `pair=False`: one vcan interface, every socket on it one node (`peer` is the same name).
    `pair=True`: two vxcan interfaces joined as two nodes on a wire, `name` and `peer`: what one
    sends goes through its own qdisc to the other. On a single vcan a frame reaches the other
    sockets by the kernel's local echo, which a qdisc never sees, so netem's loss and delay
    need the pair.
    """

    def __init__(self, *, pair: bool = False) -> None:
        tag = uuid.uuid4().hex[:6]
        if pair:
            insmod("vxcan")
            self.name, self.peer = f"vxa{tag}", f"vxb{tag}"
            run("ip", "link", "add", self.name, "type", "vxcan", "peer", "name", self.peer)
            run("ip", "link", "set", self.peer, "up")
        else:
            insmod("vcan")
            self.name = self.peer = f"vcan{tag}"
            run("ip", "link", "add", self.name, "type", "vcan")
        run("ip", "link", "set", self.name, "up")

    def set_up(self, up: bool) -> None:
        run("ip", "link", "set", self.name, "up" if up else "down")

    def qdisc(self, *spec: str, on: str | None = None) -> None:
        """Replace the root qdisc of `on` (default `name`): `plug limit 4`, `netem loss 100%`…"""
        run("tc", "qdisc", "replace", "dev", on or self.name, "root", *spec)

    def close(self) -> None:
        with contextlib.suppress(ToolError):
            run("ip", "link", "del", self.name)  # a vxcan pair goes as one


class GpioSim:
    """A gpio-sim chip labelled `label` whose lines are named `names`, live; `close` removes it."""

    def __init__(self, label: str, names: list[str]) -> None:
        insmod("gpio-sim")
        self.config = CONFIGFS_GPIO_SIM / f"bywire-{uuid.uuid4().hex[:6]}"
        bank = self.config / "bank0"
        bank.mkdir(parents=True)
        (bank / "label").write_text(label)
        (bank / "num_lines").write_text(str(len(names)))
        for offset, name in enumerate(names):
            (bank / f"line{offset}").mkdir()
            (bank / f"line{offset}" / "name").write_text(name)
        (self.config / "live").write_text("1")
        self.names = names
        chip = (bank / "chip_name").read_text().strip()
        self.path = Path("/dev") / chip
        self._sysfs = Path("/sys/devices/platform") / (self.config / "dev_name").read_text().strip()
        self._sysfs /= chip

    def level(self, name: str) -> bool:
        """The line's level as the chip drives it (gpio-sim's own sysfs)."""
        offset = self.names.index(name)
        return (self._sysfs / f"sim_gpio{offset}" / "value").read_text().strip() == "1"

    def set_pull(self, name: str, *, up: bool) -> None:
        """What drives input line `name` from outside (gpio-sim's `pull`): up, high (an E-stop's
        closed circuit: released), or down, low (open: pressed, or its wire broken). It acts
        on a line a consumer holds as an input, edge events included."""
        offset = self.names.index(name)
        (self._sysfs / f"sim_gpio{offset}" / "pull").write_text("pull-up" if up else "pull-down")

    def close(self) -> None:
        """The chip goes away (configfs `live` = 0), as an unplugged GPIO expander does."""
        if not self.config.exists():
            return
        (self.config / "live").write_text("0")
        bank = self.config / "bank0"
        for line in sorted(bank.glob("line*")):
            line.rmdir()
        bank.rmdir()
        self.config.rmdir()


def pwm_sim_gone() -> None:
    """No PWM simulator (a board without the PWM overlay)."""
    for chip in (PWM_SIM_DEVICE / "pwm").glob("pwmchip*"):
        for channel in chip.glob("pwm[0-9]*"):  # an exported channel holds the module
            (chip / "unexport").write_text(channel.name.removeprefix("pwm"))
    rmmod("bywire_pwm_sim")


def pwm_sim(npwm: int = 2) -> Path:
    """A fresh PWM simulator (every channel unexported, period 0): its /sys/class/pwm chip."""
    pwm_sim_gone()
    insmod("bywire_pwm_sim", f"npwm={npwm}")
    chip = next((PWM_SIM_DEVICE / "pwm").glob("pwmchip*"))
    return Path("/sys/class/pwm") / chip.name


def pwm_applied(channel: int) -> tuple[int, int, bool]:
    """(period_ns, duty_ns, enabled) as the PWM chip was last told by the core."""
    for line in (PWM_SIM_DEVICE / "applied").read_text().splitlines():
        number, period_ns, duty_ns, enabled = (int(word) for word in line.split())
        if number == channel:
            return period_ns, duty_ns, bool(enabled)
    raise LookupError(f"no PWM channel {channel}")


def adapter_number(name: str) -> int:
    """The bus number of the I2C adapter called `name`."""
    for adapter in sorted(SYS_I2C.glob("i2c-*")):
        if (adapter / "name").read_text().strip() == name:
            return int(adapter.name.removeprefix("i2c-"))
    raise LookupError(f"no I2C adapter {name!r}")


class I2cStub:
    """The kernel's i2c-stub with one chip at the DAC's address: an SMBus-only adapter."""

    NAME = "SMBus stub driver"

    def __init__(self) -> None:
        rmmod("i2c-stub")  # a fresh chip: every register 0
        insmod("i2c-stub", f"chip_addr=0x{DAC_ADDRESS:02x}")
        self.bus = adapter_number(self.NAME)

    def code(self, channel: int) -> int:
        """The channel's code from the bytes an I2C-block write left in the stub's registers:
        its control byte was the command, MSB and LSB the two registers from there."""
        control = dac6574.encode_write(channel, 0)[0]
        with SMBus(self.bus) as bus:
            msb, lsb = (bus.read_byte_data(DAC_ADDRESS, control + index) for index in (0, 1))
        return dac6574.decode_write(bytes((control, msb, lsb)))[1]

    def close(self) -> None:
        rmmod("i2c-stub")


class I2cSim:
    """tests/kernel/modules/bywire_i2c_sim.ko: plain I2C, every message kept."""

    NAME = "bywire-i2c-sim"

    def __init__(self) -> None:
        rmmod("ti_dac5571")
        rmmod("bywire_i2c_sim")
        insmod("bywire_i2c_sim", f"address=0x{DAC_ADDRESS:02x}")
        self.bus = adapter_number(self.NAME)
        self._adapter = SYS_I2C / f"i2c-{self.bus}"
        self._seen = 0
        self._messages: list[bytes] = []

    def written(self) -> list[bytes]:
        """Every message written to the device since this object was made, oldest first.
        AssertionError if the module's window (64 messages) passed some by unread."""
        for line in (self._adapter / "written").read_text().splitlines():
            number_text, _, data = line.partition(" ")
            number = int(number_text)
            if number <= self._seen:
                continue
            assert number == self._seen + 1, f"I2C read-back missed {number - self._seen - 1}"
            self._seen = number
            self._messages.append(bytes.fromhex(data))
        return list(self._messages)

    def code(self, channel: int) -> int:
        """The channel's code as the device holds it: from the newest frame for that channel
        (`latest`: the last message for each control byte); 0 if none or powered down."""
        newest: tuple[int, int] = (0, 0)
        for line in (self._adapter / "latest").read_text().splitlines():
            number_text, _, data = line.partition(" ")
            with contextlib.suppress(ValueError):  # not a DAC6574 frame: no code
                frame = dac6574.decode_frame(bytes.fromhex(data))
                if frame.channel == channel and int(number_text) > newest[0]:
                    code = frame.code if isinstance(frame, dac6574.Write) else 0
                    newest = (int(number_text), code)
        return newest[1]

    def set_present(self, present: bool) -> None:
        """False: the device stops acknowledging (power or cable lost)."""
        (self._adapter / "present").write_text("1" if present else "0")

    def bind_driver(self) -> Path:
        """The kernel's ti-dac5571 bound to the device as a DAC6574: its IIO directory."""
        insmod("ti-dac5571")
        (self._adapter / "new_device").write_text(f"dac6574 0x{DAC_ADDRESS:02x}")
        client = SYS_I2C / f"{self.bus}-{DAC_ADDRESS:04x}"
        return next(client.glob("iio:device*"))

    def close(self) -> None:
        client = SYS_I2C / f"{self.bus}-{DAC_ADDRESS:04x}"
        if client.exists():
            (self._adapter / "delete_device").write_text(f"0x{DAC_ADDRESS:02x}")
        rmmod("bywire_i2c_sim")


CLOSED_RC_LINES: set[int] = set()  # RC lines the host closed for good in this guest


class HostLine:
    """The control line to the host; what it asks for arrives on the RC tty from outside."""

    def __init__(self, tty_path: str = RC_TTY) -> None:
        self.line = int(tty_path.removeprefix("/dev/ttyS"))
        self._fd = os.open(CONTROL_TTY, os.O_WRONLY | os.O_NOCTTY)
        tty.setraw(self._fd)
        attributes = termios.tcgetattr(self._fd)
        attributes[1] &= ~termios.OPOST  # no \n -> \r\n on the way out
        termios.tcsetattr(self._fd, termios.TCSANOW, attributes)

    def send_rc(self, data: bytes) -> None:
        """Put `data` on the RC receiver's line, from the host."""
        self._write(f"w {self.line} {data.hex()}\n")

    def close_rc(self) -> None:
        """The host closes its end of the RC line, for good (end of file on the guest's tty)."""
        self._write(f"close {self.line}\n")
        CLOSED_RC_LINES.add(self.line)

    @property
    def rc_open(self) -> bool:
        """Whether the host still carries this RC line (no test closed it in this guest)."""
        return self.line not in CLOSED_RC_LINES

    def drain(self, limit_s: float = DRAIN_LIMIT_S) -> None:
        """Make the RC tty raw (no echo, no line editing, as a receiver's UART is used) and
        empty: every byte an earlier test had the host put on the line, still on its way or
        waiting in the host's pipe while no process held the tty open, is read and dropped.

        The host carries this line's requests in order, so once a marker asked for now arrives,
        nothing asked for before it is left on the way. AssertionError if it does not arrive
        within `limit_s` (a line the host closed has none to drain)."""
        if not self.rc_open:
            return
        marker = b"\xa5" + uuid.uuid4().bytes  # no IBUS frame starts with 0xA5
        fd = os.open(f"/dev/ttyS{self.line}", os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(fd)
            # What the tty already holds goes at once; the flush also lifts a throttle that a
            # full input buffer left on the line while nobody read it.
            termios.tcflush(fd, termios.TCIFLUSH)
            self.send_rc(marker)
            seen = b""
            deadline_s = time.monotonic() + limit_s
            while marker not in seen:
                assert time.monotonic() < deadline_s, f"RC line {self.line} not drained"
                ready, _, _ = select.select([fd], [], [], 0.1)
                if ready:
                    seen = (seen + os.read(fd, 4096))[-4096:]
        finally:
            os.close(fd)

    def _write(self, text: str) -> None:
        data = text.encode("ascii")
        while data:
            data = data[os.write(self._fd, data) :]

    def close(self) -> None:
        os.close(self._fd)
