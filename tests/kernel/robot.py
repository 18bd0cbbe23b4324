"""`bywire run` on the linux backend inside the guest kernel, and the world around it.

`KernelRobot` makes the robot's devices (a vcan interface, a gpio-sim chip with the robot's line
names, the PWM simulator, a DAC on i2c-dev) and starts `bywire run` as a process of its own on
them. From outside it drives the robot as the robot is driven: the simulated RC transmitter
(`Transmitter`: real IBUS frames every 7.7 ms, put on the RC tty by the host) and the simulated
higher-level computer (`Computer`: movement, lights and control commands at 50 Hz with counter
and CRC on the vcan interface, reports read back from it); both send from a process of their own
above bywire's real-time priority, as other machines would (`Senders`). `observe()` reads every
output back from the kernel (gpio-sim's levels, what the PWM chip was told, the DAC's bytes on
the I2C bus) into the simulator's own `Observation`, so a scenario's expectations judge it by the
same code.
"""

from __future__ import annotations

import contextlib
import json
import select
import subprocess
import sys
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import can

from bywire.config import RobotConfig, output_lines, parse_config
from bywire.control.lights import LIGHT_LINES, LightOutputs
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, StatusReport
from bywire.protocol import dac6574, dbc
from bywire.sim.observe import Observation
from tests.hal.linux.bench import GPIO_LABEL, line_names
from tests.kernel import guest

START_LIMIT_S = 60.0  # bywire's first start in the guest imports everything from hostfs
WARM_UP_S = 2.0  # a new process in the guest is slow while it first touches its memory
POLL_PERIOD_S = 0.02  # a reading is ~20 sysfs reads, each a round trip through the host
ANSWER_LIMIT_S = 5.0  # the senders apply a request at once: they run ahead of everything here

SENDERS_ABOVE = 10  # the senders' SCHED_FIFO priority over bywire's (tests/kernel/senders.py)
REPO = Path(__file__).resolve().parents[2]


class Senders:
    """The transmitter and the computer's commands in a process of their own, above bywire's
    real-time priority, as other machines are (tests/kernel/senders.py says why)."""

    def __init__(self, folder: Path, robot: RobotConfig, channel: str, rc_tty: str) -> None:
        """`robot`: the robot file at `folder`/robot.toml; `channel`: the computer's CAN
        interface."""
        self.log_path = folder / "senders.log"
        priority = min(99, robot.realtime.priority + SENDERS_ABOVE)
        arguments = [str(folder / "robot.toml"), channel, rc_tty, str(priority)]
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.kernel.senders", *arguments, str(self.log_path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            cwd=REPO,
        )
        self._lock = threading.Lock()
        self._answer("ready", START_LIMIT_S)

    def ask(self, request: Mapping[str, Any]) -> None:
        """`request` applied by the senders (returns once it is)."""
        assert self.process.stdin is not None
        with self._lock:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
            self._answer("ok", ANSWER_LIMIT_S)

    def _answer(self, expected: str, limit_s: float) -> None:
        assert self.process.stdout is not None
        ready, _, _ = select.select([self.process.stdout], [], [], limit_s)
        line = self.process.stdout.readline().strip() if ready else "(nothing)"
        assert line == expected, f"the senders answered {line!r}, not {expected!r}: {self.log()}"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def stalls(self, who: str) -> list[tuple[float, float]]:
        """(monotonic s, gap s) of each gap over the senders' STALL_S between two sends of
        `who` ("transmitter" or "computer")."""
        words = (line.split() for line in self.log().splitlines())
        return [(float(w[2]), float(w[3])) for w in words if w[:2] == ["stall", who]]

    def play(self, start_s: float, events: list[dict[str, Any]]) -> None:
        """Actions ({"at_s", "kind", "values"}, in time order), each applied by the senders at
        monotonic `start_s` + its `at_s` (tests/kernel/senders.py `Schedule`)."""
        self.ask({"play": start_s, "events": events})

    def applied(self) -> dict[int, float]:
        """When each played action was applied (its index: monotonic s)."""
        words = (line.split() for line in self.log().splitlines())
        return {int(w[1]): float(w[2]) for w in words if w[:1] == ["applied"]}

    def errors(self) -> list[str]:
        return [line[6:] for line in self.log().splitlines() if line.startswith("error ")]

    def close(self) -> None:
        assert self.process.stdin is not None
        with contextlib.suppress(BrokenPipeError):
            self.process.stdin.close()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


class Transmitter:
    """The operator's sticks and switches (the senders' transmitter: IBUS frames every 7.7 ms
    on the RC tty)."""

    def __init__(self, senders: Senders) -> None:
        self._senders = senders
        self._sending = True

    def apply(self, values: Mapping[str, Any]) -> None:
        """A scenario's `rc = {…}` action."""
        self._senders.ask({"kind": "rc", "values": dict(values)})

    @property
    def sending(self) -> bool:
        return self._sending

    @sending.setter
    def sending(self, sending: bool) -> None:
        self._senders.ask({"transmitter": sending})
        self._sending = sending

    @property
    def stalls(self) -> list[tuple[float, float]]:
        return self._senders.stalls("transmitter")


class Computer:
    """The higher-level computer on the vcan interface: its commands at 50 Hz (sent by the
    senders' process), its reports read back here."""

    def __init__(self, channel: str, senders: Senders) -> None:
        heard = [ModeReport, ErrorReport, StatusReport]  # filtered in the kernel: fewer wake-ups
        filters: list[Any] = [
            {"can_id": dbc.frame_id(kind), "can_mask": 0x7FF, "extended": False} for kind in heard
        ]
        self.bus = can.Bus(interface="socketcan", channel=channel, can_filters=filters)
        self._senders = senders
        self.mode: ModeReport | None = None
        self.errors: ErrorReport | None = None
        self.status: StatusReport | None = None
        self.reports = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._receive_loop, name="hlc-rx", daemon=True)
        self._thread.start()

    def apply(self, kind: str, values: Mapping[str, Any]) -> None:
        """A scenario's `hlc`, `hlc_lights` or `hlc_control` action (sending starts at the
        first)."""
        self._senders.ask({"kind": kind, "values": dict(values)})

    @property
    def stalls(self) -> list[tuple[float, float]]:
        return self._senders.stalls("computer")

    @property
    def send_errors(self) -> list[str]:
        return self._senders.errors()

    def _receive_loop(self) -> None:
        while not self._stop.is_set():
            try:
                message = self.bus.recv(0.1)
            except can.CanError:
                time.sleep(0.05)  # the interface is down: the robot cannot be heard either
                continue
            if message is None or message.is_error_frame:
                continue
            if message.arbitration_id in dbc.report_ids():
                report = dbc.decode_report(message.arbitration_id, message.data)
                if isinstance(report, ModeReport):
                    self.mode = report
                elif isinstance(report, ErrorReport):
                    self.errors = report
                elif isinstance(report, StatusReport):
                    self.status = report
                self.reports += 1

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.bus.shutdown()


class KernelRobot:
    """The robot's devices, `bywire run` on them, and its transmitter and computer."""

    def __init__(
        self,
        folder: Path,
        *,
        dac: str = "plain-i2c",
        extra_config: str = "",
        rc_tty: str = guest.RC_TTY,
        estop_line: str = "none",
    ) -> None:
        self._devices = contextlib.ExitStack()
        self.estop_line = estop_line  # a line of the chip, or "none"
        self.vcan = guest.Vcan(pair=True)  # the robot on one end, the computer on the other
        self._devices.callback(self.vcan.close)
        self.gpio = guest.GpioSim(GPIO_LABEL, line_names())
        self._devices.callback(self.gpio.close)
        guest.pwm_sim()
        self.dac: guest.I2cStub | guest.I2cSim = (
            guest.I2cStub() if dac == "smbus-only" else guest.I2cSim()
        )
        self._devices.callback(self.dac.close)
        self.host = guest.HostLine(rc_tty)
        self.host.drain()
        self._devices.callback(self.host.close)
        self.config_path = folder / "robot.toml"
        text = guest.robot_config(self.vcan.name, self.dac.bus, rc_tty, estop_line)
        self.config_path.write_text(text + extra_config)
        try:
            self.config = parse_config(self.config_path.read_text())
        except BaseException:
            self._devices.close()  # a refused file leaves no chip behind for the next test
            raise
        self.lines = {name: str(line.line) for name, line in output_lines(self.config).items()}
        self.senders = Senders(folder, self.config, self.vcan.peer, rc_tty)
        self._devices.callback(self.senders.close)
        self.transmitter = Transmitter(self.senders)
        self.computer = Computer(self.vcan.peer, self.senders)
        self._devices.callback(self.computer.close)
        self.log_path = folder / "bywire.log"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        """`bywire run` in a process of its own; returns when its reports arrive."""
        command = [str(Path(sys.executable).with_name("bywire")), "run", "--config"]
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                [*command, str(self.config_path)], stdout=log, stderr=subprocess.STDOUT
            )
        self.wait_for("its first reports", lambda: self.computer.mode is not None, START_LIMIT_S)
        time.sleep(WARM_UP_S)
        if self.estop_line != "none":
            # bywire holds the line pulled down (an open circuit is a press): the button's
            # circuit closes only now, so the robot started with its E-stop pressed
            self.gpio.set_pull(self.estop_line, up=True)
        # The transmitter rests at STOP: once the new process's slow first passes are behind it
        # (a pass that overran, RC frames it read late) the switch acknowledges what they
        # latched. The robot is ready to arm when it says nothing is latched.
        if self.host.rc_open:
            self.wait_for("nothing latched", self._at_rest, START_LIMIT_S)

    def _at_rest(self) -> bool:
        mode = self.computer.mode
        return mode is not None and not mode.stop_latched

    def wait_for(self, what: str, condition: Any, limit_s: float = 5.0) -> float:
        """Poll `condition` until it holds; the seconds it took. AssertionError naming `what`."""
        started_s = time.monotonic()
        while not condition():
            if self.process is not None and self.process.poll() is not None:
                raise AssertionError(f"bywire exited before {what}: {self.log()}")
            if time.monotonic() - started_s > limit_s:
                raise AssertionError(
                    f"no {what} within {limit_s} s; {self.reports()}; bywire: {self.log()[-2000:]}"
                )
            time.sleep(POLL_PERIOD_S)
        return time.monotonic() - started_s

    def reports(self) -> str:
        """The robot's last reports as the computer heard them (for a failure's message)."""
        computer = self.computer
        flags = None if computer.errors is None else computer.errors.flags
        return f"last ModeReport {computer.mode}, flags {flags!r}, {computer.reports} reports"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def observe(self, now_s: float) -> Observation:
        """The robot's outputs as the kernel's devices hold them (mode and latch: its report)."""
        dac = self.config.drive.dac
        levels = {name: self.gpio.level(line) for name, line in self.lines.items()}
        mode = self.computer.mode
        period_ns, duty_ns, enabled = guest.pwm_applied(1)
        steering_ns = guest.pwm_applied(0)[1]
        return Observation(
            time_s=now_s,
            mode=ControlMode.STOP if mode is None else mode.control_mode,
            latched=mode is not None and mode.stop_latched,
            gear=Gear.NEUTRAL if mode is None else mode.gear,
            steering_cmd_norm=0.0, throttle_cmd_norm=0.0, brake_cmd_norm=0.0,
            steering_pulse_s=steering_ns / 1e9, steering_changed_at_s=0.0,
            throttle_volts=self._volts(dac.throttle_channel),
            regen_volts=self._volts(dac.regen_channel),
            hydrobrake_duty=duty_ns / period_ns if enabled and period_ns else 0.0,
            motors_enabled=levels["motors_enable"],
            ebrake_engaged=not levels["ebrake_release"],
            speed_mps=0.0, steering_actual_norm=0.0, distance_m=0.0,
            lights=LightOutputs(**{name: levels[light.line] for name, light in LIGHT_LINES}),
            error_flags=0 if self.computer.errors is None else int(self.computer.errors.flags),
        )  # fmt: skip

    def throttle_volts(self) -> float:
        """The throttle output's volts, from the DAC's bytes on the bus."""
        return self._volts(self.config.drive.dac.throttle_channel)

    def _volts(self, channel: int) -> float:
        code = self.dac.code(channel)
        return dac6574.volts_from_code(code, self.config.drive.dac.vref_volts)

    def stop(self) -> int:
        """SIGTERM, as systemd stops it; its exit status."""
        assert self.process is not None
        if self.process.poll() is None:
            self.process.terminate()
        return self.process.wait(timeout=10)

    def close(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        self._devices.close()
