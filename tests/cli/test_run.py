"""`bywire run` as a process on the stand-ins: IBUS on a pty and CAN frames drive the outputs, a
signal ends it with every output de-energised, and a device problem is one line, exit 2.

The process is `tests/hal/linux/launch_bywire.py`: the real CLI, with the file-backed gpiod
stand-in and the higher-level computer on its virtual CAN channel (see its docstring). Waiting
for the process polls the files it writes, with generous limits; nothing sleeps blindly.

The bench runs bywire at the kernel's normal priority, as a user's machine would. A host busy
with other work can then keep its loop from its deadlines; bywire rightly latches TIMING_FAULT
and stays in STOP. Such an attempt is void, not failed, when the host is shown busy (its CPU
pressure, `host_busy`) and bywire still ended as it must (exit 0 on SIGTERM, no traceback, the
outputs de-energised); the test tries again, up to VOID_ATTEMPTS times. A TIMING_FAULT on a host
with time to spare fails, as does one on every attempt.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from bywire.bench.machine import CPU_PRESSURE, cpu_pressure_s
from bywire.cli.main import main
from bywire.model import ControlMode
from tests.hal.linux import fake_gpiod
from tests.hal.linux.bench import Bench, make_bench
from tests.hal.linux.fake_sysfs import make_can_netdev
from tests.hal.linux.pty_rc import PtyRcLine

LAUNCHER = Path(__file__).resolve().parents[1] / "hal" / "linux" / "launch_bywire.py"
CENTRE_NS = 1_500_000
LIMIT_S = 30.0  # generous: a loaded CI machine may be slow to start python-can and cantools
VOID_ATTEMPTS = 3


class HostTooSlowError(Exception):
    """bywire latched TIMING_FAULT: its host kept the loop from its deadlines (the attempt is
    void, see the module's docstring)."""


class Robot:
    """A running `bywire run` on a bench, with its RC line and higher-level computer."""

    def __init__(
        self,
        bench: Bench,
        line: PtyRcLine | None,
        *,
        user: int | None = None,
        notify_socket: Path | None = None,
        extra: tuple[str, ...] = (),
        config_lines: tuple[str, ...] = (),
    ) -> None:
        self.bench, self.line = bench, line
        self.hlc = bench.root / "hlc"
        self.hlc.mkdir(exist_ok=True)
        self.hlc.chmod(0o777)  # the higher-level computer writes here, as whichever user runs
        self.config = config = bench.root / "robot.toml"
        config.write_text(bench.config_text() + "".join(f"\n{line}" for line in config_lines))
        args = ["run", "--config", str(config), "--sysfs-root", str(bench.sysfs)]
        args += ["--dev-root", str(bench.dev), *extra]
        command = [sys.executable, str(LAUNCHER), str(self.hlc), bench.can_channel, "--", *args]
        if user is not None:
            command = ["setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *command]
        env = dict(os.environ)
        if notify_socket is not None:
            env["NOTIFY_SOCKET"] = str(notify_socket)
        self.started = (time.monotonic(), cpu_pressure_s())  # what `host_busy` counts from
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        )

    def wait_for(self, what: str, condition: Callable[[], bool]) -> None:
        deadline_s = time.monotonic() + LIMIT_S
        while not _holds(condition):
            if self.process.poll() is not None:
                pytest.fail(
                    f"bywire exited ({self.process.returncode}) before {what}: {self.errors()}"
                )
            if "TIMING_FAULT" in _holds_value(lambda: self.reports()["flags"], ""):
                self._timing_fault(what)
            if time.monotonic() > deadline_s:
                pytest.fail(f"no {what} within {LIMIT_S} s; {self._story()}")
            time.sleep(0.02)

    def _timing_fault(self, what: str) -> None:
        """bywire latched TIMING_FAULT: the attempt is void if the host was busy and bywire
        still ended as it must (exit 0 on the story's SIGTERM, no traceback); it fails
        otherwise: a TIMING_FAULT on a host with time to spare is bywire's own."""
        busy = host_busy(self.started)
        story = self._story()
        if busy is None:
            pytest.fail(f"TIMING_FAULT latched before {what} on a host that was not busy; {story}")
        assert self.process.returncode == 0, story
        assert "Traceback" not in self._output[1], story
        raise HostTooSlowError(f"TIMING_FAULT latched before {what} ({busy}); {story}")

    def _story(self) -> str:
        """What a wait that timed out needs to tell: the last reports, then bywire's own log
        (the process stopped with SIGTERM to read it)."""
        try:
            last: object = self.reports()
        except (OSError, ValueError) as error:
            last = f"none readable ({error})"
        self.process.terminate()
        try:
            self._output = self.process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self._output = self.process.communicate()
        return f"last reports {last}; bywire's log: {self._output[1][-3000:]}"

    def finish(self) -> int:
        try:
            return self.process.wait(timeout=LIMIT_S)
        finally:
            self._output = self.process.communicate()

    def errors(self) -> str:
        if self.process.poll() is None:
            return ""
        if not hasattr(self, "_output"):
            self._output = self.process.communicate()
        return self._output[1]

    def command(self, **movement: Any) -> None:
        temporary = self.hlc / "movement.tmp"
        temporary.write_text(json.dumps(movement))
        os.replace(temporary, self.hlc / "movement.json")

    def reports(self) -> dict[str, Any]:
        reports: dict[str, Any] = json.loads((self.hlc / "reports.json").read_text())
        return reports

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.communicate()


BUSY_PRESSURE_PCT = 10.0
"""A host on which some task waited for a CPU this share of an attempt (the kernel's CPU
pressure, PSI "some", as `bywire bench` reads it) was busy: a TIMING_FAULT on it may be the
host's."""


def host_busy(since: tuple[float, float]) -> str | None:
    """How the host was busy since `since` (`time.monotonic()`, `cpu_pressure_s()` then), if it
    was: its CPU pressure, or without PSI a load average above its CPUs; None for a host with
    time to spare."""
    if not CPU_PRESSURE.exists():
        load = os.getloadavg()[0]
        cpus = os.cpu_count() or 1
        return f"load average {load:.2f} on {cpus} CPUs" if load > cpus else None
    started_s, pressure_then_s = since
    share_pct = 100 * (cpu_pressure_s() - pressure_then_s) / max(time.monotonic() - started_s, 1e-3)
    if share_pct >= BUSY_PRESSURE_PCT:
        return f"some task waited for a CPU {share_pct:.0f} % of the attempt"
    return None


def _holds(condition: Callable[[], bool]) -> bool:
    return bool(_holds_value(condition, False))


def _holds_value(value: Callable[[], Any], unwritten: Any) -> Any:
    try:
        return value()
    except (OSError, ValueError, KeyError):
        return unwritten  # a file the process has not written yet


def _on_a_host_that_keeps_time(tmp_path: Path, attempt: Callable[[Bench, PtyRcLine], None]) -> None:
    """Run `attempt` on a fresh bench and RC line until it is not void (`HostTooSlowError`)."""
    voided: list[str] = []
    for number in range(1, VOID_ATTEMPTS + 1):
        root = tmp_path / f"attempt-{number}"
        root.mkdir()
        line = PtyRcLine.at_rest(root / "ttyRC")
        bench = make_bench(root)
        try:
            attempt(bench, line)
            return
        except HostTooSlowError as void:
            voided.append(str(void))
            warnings.warn(f"attempt {number} void: {str(void)[:200]}", stacklevel=1)
            _assert_de_energised(bench)  # the story ended it with SIGTERM: safe all the same
        finally:
            line.close()
    pytest.fail(f"all {VOID_ATTEMPTS} attempts void, the last: {voided[-1]}")


def _stop_armed(robot: Robot) -> dict[str, Any]:
    """The RC link is up with the switch at STOP: the robot may be armed."""
    return {**robot.reports(), "mode": "STOP", "armed": True}


def _steering_ns(bench: Bench) -> int:
    return bench.pwm(0)[1]


@pytest.mark.parametrize(
    "stop_signal",
    [signal.SIGINT, signal.SIGTERM, signal.SIGHUP],
    ids=["SIGINT", "SIGTERM", "SIGHUP"],
)
def test_ibus_and_can_drive_the_outputs_and_a_signal_ends_safe(
    tmp_path: Path, stop_signal: signal.Signals
) -> None:
    _on_a_host_that_keeps_time(
        tmp_path, lambda bench, line: _drive_and_signal(bench, line, stop_signal)
    )


def _drive_and_signal(bench: Bench, line: PtyRcLine, stop_signal: signal.Signals) -> None:
    robot = Robot(bench, line)
    try:
        robot.command(steering=-0.6, throttle=0.0, brake=0.5, gear="forward")
        robot.wait_for("armed in STOP", lambda: robot.reports() == _stop_armed(robot))
        assert bench.levels()["ebrake_release"] == 0
        line.transmitter.set_mode(ControlMode.RC)
        robot.wait_for("RC mode in the reports", lambda: robot.reports()["mode"] == "RC")
        line.transmitter.set_steering(0.8)
        line.transmitter.set_throttle(0.5)
        robot.wait_for("RC steering right", lambda: _steering_ns(bench) > CENTRE_NS + 200_000)
        robot.wait_for("RC throttle", lambda: bench.dac_code(0) > 0)
        assert bench.levels()["motors_enable"] == 1
        assert bench.levels()["ebrake_release"] == 1
        line.transmitter.set_throttle(0.0)
        robot.command(steering=-0.6, throttle=0.3, brake=0.0, gear="forward")
        line.transmitter.set_mode(ControlMode.CAN)
        robot.wait_for("CAN mode in the reports", lambda: robot.reports()["mode"] == "CAN")
        robot.wait_for("CAN steering left", lambda: _steering_ns(bench) < CENTRE_NS - 200_000)
        robot.process.send_signal(stop_signal)
        assert robot.finish() == 0, robot.errors()
    finally:
        robot.kill()
    _assert_de_energised(bench)
    assert "Traceback" not in robot.errors()


def test_authenticated_commands_drive_and_the_key_stays_out_of_the_log(tmp_path: Path) -> None:
    _on_a_host_that_keeps_time(tmp_path, _drive_authenticated)


def _drive_authenticated(bench: Bench, line: PtyRcLine) -> None:
    tmp_path = bench.root
    key = tmp_path / "robot.key"
    assert main(["keys", "new", str(key)]) == 0
    security = (
        "[security]",
        "enabled = true",
        f'key_file = "{key}"',
        f'freshness_file = "{tmp_path / "freshness.json"}"',
    )
    (bench.root / "hlc" / "private").mkdir(parents=True)
    shutil.copy(key, bench.root / "hlc" / "private" / "hlc.key")  # the computer holds the key
    freshness = tmp_path / "freshness.json"
    # The controller refuses to start without its freshness file; the one deliberate act:
    robot = Robot(bench, line, config_lines=security)
    assert robot.finish() == 2
    assert f"{freshness}: no freshness file: refusing to start;" in robot.errors()
    assert "bywire keys reset-freshness --config" in robot.errors()
    assert main(["keys", "reset-freshness", "--config", str(robot.config)]) == 0
    robot = Robot(bench, line, config_lines=security)
    try:
        robot.command(steering=-0.6, throttle=0.0, brake=0.0, gear="forward")
        robot.wait_for("armed in STOP", lambda: robot.reports() == _stop_armed(robot))
        line.transmitter.set_mode(ControlMode.CAN)
        robot.wait_for("CAN mode in the reports", lambda: robot.reports()["mode"] == "CAN")
        robot.wait_for("CAN steering left", lambda: _steering_ns(bench) < CENTRE_NS - 200_000)
        robot.process.send_signal(signal.SIGTERM)
        assert robot.finish() == 0, robot.errors()
    finally:
        robot.kill()
    _assert_de_energised(bench)
    log = robot.errors()
    assert "authentication: on (SecOC profile 3" in log
    assert key.read_text().strip() not in log.lower()
    trip = json.loads(freshness.read_text())["trip"]
    assert f"trip counter {trip}," in log  # moved on and on the disk before the loop ran
    assert json.loads((bench.root / "hlc" / "freshness.json").read_text())["trip"] == trip


@pytest.fixture
def notify_socket(tmp_path: Path) -> Iterator[tuple[Path, socket.socket]]:
    """A service manager's notification socket, as systemd gives one in NOTIFY_SOCKET."""
    path = tmp_path / "notify.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(str(path))
        sock.settimeout(0.0)
        yield path, sock


def _notifications(sock: socket.socket) -> list[str]:
    received = []
    with contextlib.suppress(BlockingIOError):
        while True:
            received.append(sock.recv(256).decode())
    return received


def test_a_second_signal_while_stopping_still_ends_safe_and_tells_systemd(
    tmp_path: Path, notify_socket: tuple[Path, socket.socket]
) -> None:
    _on_a_host_that_keeps_time(
        tmp_path, lambda bench, line: _stop_twice(bench, line, notify_socket)
    )


def _stop_twice(bench: Bench, line: PtyRcLine, notify_socket: tuple[Path, socket.socket]) -> None:
    path, sock = notify_socket
    _notifications(sock)  # what a void attempt before this one said
    robot = Robot(bench, line, notify_socket=path)
    try:
        robot.command(steering=0.0, throttle=0.0, brake=0.5, gear="forward")
        robot.wait_for("armed in STOP", lambda: robot.reports() == _stop_armed(robot))
        line.transmitter.set_mode(ControlMode.RC)
        robot.wait_for("RC mode in the reports", lambda: robot.reports()["mode"] == "RC")
        line.transmitter.set_throttle(0.5)
        robot.wait_for("RC throttle", lambda: bench.dac_code(0) > 0)
        robot.process.send_signal(signal.SIGTERM)
        started = time.monotonic()
        while robot.process.poll() is None and time.monotonic() - started < LIMIT_S:
            robot.process.send_signal(signal.SIGINT)  # impatient: again and again while it stops
            time.sleep(0.002)
        assert robot.finish() == 0, robot.errors()
    finally:
        robot.kill()
    _assert_de_energised(bench)
    assert "Traceback" not in robot.errors()
    messages = _notifications(sock)
    assert "READY=1" in messages
    assert messages[-1] == "STOPPING=1"


def _assert_de_energised(bench: Bench) -> None:
    state = bench.gpio_state()
    assert set(state["levels"].values()) == {0}
    assert state["released"] is True
    assert set(state["requested"].values()) == {0}  # requested low: no glitch at start
    assert bench.pwm(0)[1:] == (0, 0)
    assert bench.pwm(1)[1:] == (0, 0)
    assert [bench.dac_code(channel) for channel in range(4)] == [0, 0, 0, 0]


def _no_gpio_chip(bench: Bench) -> None:
    bench.gpio_chip.unlink()


def _no_pwm_chip(bench: Bench) -> None:
    (bench.sysfs / "class" / "pwm" / bench.pwm_chip.name).unlink()


def _no_dac(bench: Bench) -> None:
    (bench.sysfs / "bus" / "iio" / "devices" / "iio:device0").unlink()


def _no_rc_receiver(bench: Bench) -> None:
    bench.rc_link.unlink(missing_ok=True)


def _kvaser(bench: Bench) -> None:
    bench.can_interface = "kvaser"


def _socketcan_down(bench: Bench) -> None:
    make_can_netdev(bench.sysfs, bench.can_channel, "down")
    bench.can_interface = "socketcan"


def _unknown_interface(bench: Bench) -> None:
    bench.can_interface = "vcan"


@pytest.mark.parametrize(
    ("break_it", "expected"),
    [
        (_no_gpio_chip, "GPIO: no chip 'bywire-test-gpio'"),
        (_no_pwm_chip, "PWM: no chip 'fe20c000.pwm'"),
        (_no_dac, "i2c-1 does not exist: enable I2C"),
        (_no_rc_receiver, "ttyRC does not exist: enable the UART"),
        (_kvaser, "CAN kvaser"),
        (_socketcan_down, "is down: sudo ip link set"),
        (_unknown_interface, 'can.interface = "vcan": not allowed'),
    ],
    ids=["gpio", "pwm", "dac", "uart", "can-driver", "can-down", "can-interface"],
)
def test_a_missing_device_is_one_line_and_exit_2(
    tmp_path: Path, line: PtyRcLine, break_it: Callable[[Bench], None], expected: str
) -> None:
    bench = make_bench(tmp_path)
    break_it(bench)
    robot = Robot(bench, line)
    status = robot.finish()
    errors = robot.errors().strip().splitlines()
    assert status == 2
    assert len(errors) == 1, errors
    assert expected in errors[0]
    assert errors[0].startswith("bywire run: error: ")
    if Path(f"{bench.gpio_chip}.state.json").exists():  # requested before the failure
        assert fake_gpiod.read_state(bench.gpio_chip)["released"] is True


@pytest.mark.skipif(
    os.geteuid() == 0 and shutil.which("setpriv") is None, reason="root, and no setpriv to drop it"
)
@pytest.mark.parametrize(
    ("denied", "expected"),
    [("uart", "add the user to group dialout"), ("pwm", "add the user to group gpio")],
)
def test_a_device_the_user_may_not_open_says_which_group(denied: str, expected: str) -> None:
    """Run as an unprivileged user (nobody, through setpriv, when the tests run as root), so
    that the kernel itself refuses the device file."""
    user = 65534 if os.geteuid() == 0 else None
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        root.chmod(0o755)
        bench = make_bench(root)
        bench.dev.chmod(0o777)  # the gpiod stand-in writes its state there
        for path in bench.sysfs.rglob("*"):
            if path.is_file() and (denied != "pwm" or "pwm" not in str(path)):
                path.chmod(0o666)
        line = PtyRcLine(bench.rc_link)
        try:
            if denied != "uart":
                os.chmod(os.path.realpath(bench.rc_link), 0o666)
            robot = Robot(bench, line, user=user)
            status = robot.finish()
        finally:
            line.close()
    errors = robot.errors().strip().splitlines()
    assert status == 2
    assert errors[0].startswith("bywire run: error: ")
    # Every device with the problem is named (both PWM channels), each saying what to do.
    assert all("permission denied" in error and expected in error for error in errors), errors
    assert len(errors) == (2 if denied == "pwm" else 1)


def test_every_missing_device_is_named_at_once(tmp_path: Path, line: PtyRcLine) -> None:
    bench = make_bench(tmp_path)
    _no_pwm_chip(bench)
    _no_rc_receiver(bench)
    robot = Robot(bench, line)
    status = robot.finish()
    errors = robot.errors().strip().splitlines()
    assert status == 2
    assert len(errors) == 2, errors
    assert "PWM: no chip 'fe20c000.pwm'" in errors[0]
    assert "ttyRC does not exist: enable the UART" in errors[1]


def test_check_opens_each_device_reports_it_and_energises_nothing(
    tmp_path: Path, line: PtyRcLine
) -> None:
    bench = make_bench(tmp_path)
    robot = Robot(bench, line, extra=("--check",))
    assert robot.finish() == 0, robot.errors()
    out = robot._output[0]
    for device in ("GPIO output lines", "DAC", "steering PWM", "RC receiver (UART)", "CAN bus"):
        assert f"ready    {device}" in out
    assert "6 of 6 devices ready" in out
    assert 'E-stop: none (the robot file says [estop] line = "none")' in out  # issue 44
    assert [bench.dac_code(channel) for channel in range(4)] == [0, 0, 0, 0]
    assert fake_gpiod.read_state(bench.gpio_chip)["released"] is True


def test_check_names_each_problem_and_exits_2(tmp_path: Path, line: PtyRcLine) -> None:
    bench = make_bench(tmp_path)
    _no_dac(bench)
    robot = Robot(bench, line, extra=("--check",))
    assert robot.finish() == 2
    out = robot._output[0]
    assert "PROBLEM  DAC: " in out
    assert "i2c-1 does not exist: enable I2C" in out
    assert "ready    CAN bus" in out
    assert "5 of 6 devices ready" in out
