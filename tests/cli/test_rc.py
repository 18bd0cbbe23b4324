"""`bywire rc`: a receiver on a real tty (a pty pair, the child process reading it as `bywire run`
would), the simulated transmitter, and the suggestion pasted into a robot file and checked."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.config import load_config
from bywire.control.rc_mapping import RcMapping
from bywire.hal.simulated.rc_transmitter import idle_channels
from bywire.protocol import ibus

ROOT = Path(__file__).resolve().parents[2]
ALBERT = ROOT / "config" / "albert.toml"
BYWIRE = [sys.executable, "-m", "bywire.cli.main"]
MAPPING = RcMapping()
HOLD = 20  # frames a position is held
LIMIT_S = 30.0
RC_TABLES = re.compile(
    r"^\[rc\.(steering|throttle_brake|mode_switch|gear_switch|low_beam_switch|hazard_switch)\]"
)


def _frames(channel: int, raws: list[int]) -> list[bytes]:
    channels = list(idle_channels(MAPPING))
    frames = []
    for raw in raws:
        channels[channel] = raw
        frames.append(ibus.encode_frame(channels))
    return frames


def _operator_script() -> list[bytes]:
    """Both sticks to both ends, the mode and gear switches through every position, the low
    beam on and off; the hazard switch left alone. Every tenth frame has a flipped checksum."""
    stick = [1500] * HOLD + list(range(1500, 1000, -20)) + list(range(1000, 2001, 20))
    stick += list(range(2000, 1500, -20)) + [1500] * HOLD
    three = [1000] * HOLD + [1500] * HOLD + [2000] * HOLD + [1000] * HOLD
    frames = _frames(MAPPING.steering.channel, stick)
    frames += _frames(MAPPING.throttle_brake.channel, stick)
    frames += _frames(MAPPING.mode_switch.channel, three)
    frames += _frames(MAPPING.gear_switch.channel, [*three[HOLD:], 1500])
    frames += _frames(MAPPING.low_beam_switch.channel, [2000] * HOLD + [1000] * HOLD)
    return [
        frame[:-1] + bytes([frame[-1] ^ 0xFF]) if index % 10 == 9 else frame
        for index, frame in enumerate(frames)
    ]


class PtyReceiver:
    """A receiver on a pty: `script`'s frames written into the master over and over (every
    2 ms, dropped while the pty's buffer is full) until closed; the slave's name is the port."""

    def __init__(self, script: list[bytes]) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.port = os.ttyname(self.slave)
        self._script = script
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        if script:
            self._thread.start()

    def _run(self) -> None:
        while not self._stopping.is_set():
            for frame in self._script:
                if self._stopping.wait(0.002):
                    return
                try:
                    os.write(self.master, frame)
                except (BlockingIOError, OSError):
                    continue

    def close(self) -> None:
        self._stopping.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        os.close(self.master)
        os.close(self.slave)


@pytest.fixture
def receiver() -> Iterator[PtyReceiver]:
    line = PtyReceiver(_operator_script())
    yield line
    line.close()


def _bywire(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*BYWIRE, *args], capture_output=True, text=True, timeout=LIMIT_S, check=False
    )


def test_rc_reads_a_receiver_on_a_tty_counts_bad_frames_and_suggests(
    receiver: PtyReceiver, tmp_path: Path
) -> None:
    written = tmp_path / "rc.toml"
    result = _bywire(
        "rc", "--port", receiver.port, "--duration", "4", "--write-suggestion", str(written)
    )
    assert result.returncode == 0, result.stderr
    status = re.search(r"(\d+) frames, (\d+) checksum errors", result.stdout)
    assert status is not None, result.stdout
    frames, checksum_errors = int(status[1]), int(status[2])
    assert frames > 200
    assert checksum_errors >= frames // 10  # one frame in ten is corrupt: counted, dropped
    snippet = written.read_text()
    assert result.stdout.endswith(snippet)
    assert (
        "[rc.steering]\nchannel = 0\nmin_raw = 1000\ncenter_raw = 1500\nmax_raw = 2000" in snippet
    )
    assert "[rc.mode_switch]" in snippet
    assert "[rc.low_beam_switch]" in snippet
    assert "[rc.hazard_switch]" not in snippet
    assert "# rc.hazard_switch: not suggested: rested at 1 of its 2 positions (1000 µs)" in snippet
    assert f"seen on {receiver.port} (115200 8N1)" in snippet
    assert load_config(_robot_file(tmp_path, snippet)).rc.mapping == MAPPING


def test_rc_says_so_when_no_frame_arrives(tmp_path: Path) -> None:
    silent = PtyReceiver([])
    try:
        result = _bywire("rc", "--port", silent.port, "--duration", "0.5")
    finally:
        silent.close()
    assert result.returncode == 1
    assert "no IBUS frame from" in result.stderr
    assert "# rc.steering: not suggested: no frames seen on its channel" in result.stdout


def test_a_missing_port_is_one_line_and_exit_2(tmp_path: Path) -> None:
    result = _bywire("rc", "--port", str(tmp_path / "ttyNONE"), "--once")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert "RC receiver" in result.stderr
    assert str(tmp_path / "ttyNONE") in result.stderr


def _robot_file(folder: Path, snippet: str, base: Path = ALBERT) -> Path:
    """`base` with its [rc.*] stick and switch tables replaced by the snippet's: what a user
    pasting the suggestion does."""
    kept: list[str] = []
    skipping = False
    for line in base.read_text().splitlines():
        if line.startswith("["):
            skipping = RC_TABLES.match(line) is not None
        if not skipping:
            kept.append(line)
    path = folder / "robot.toml"
    path.write_text("\n".join(kept) + "\n\n" + snippet)
    return path


def test_the_sim_suggestion_for_a_half_travel_transmitter_pastes_into_albert_and_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["rc", "--sim", "--sim-travel", "50", "--config", str(ALBERT), "--duration", "12"]
    assert main([*args, "--write-suggestion", str(tmp_path / "rc.toml")]) == 0
    shown = capsys.readouterr().out
    assert "between positions: STOP" in shown  # albert's own bands at rest, 1250 µs
    robot = _robot_file(tmp_path, (tmp_path / "rc.toml").read_text())
    assert main(["config", "check", str(robot)]) == 0
    checked = capsys.readouterr().out
    assert "mode_switch (channel 6): STOP 1175..1325, RC 1425..1575, CAN 1675..1825 µs" in checked
    mapping = load_config(robot).rc.mapping
    assert mapping.mode_switch.positions_raw == (1250, 1500, 1750)
    assert mapping.low_beam_switch.positions_raw == (1250, 1750)


def test_the_default_is_the_simulated_transmitter_and_every_item_is_suggested(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["rc", "--duration", "12"]) == 0
    out = capsys.readouterr().out
    assert "simulated transmitter (sweep at 100% travel)" in out
    assert "not suggested" not in out
    assert out.count("\n[rc.") == 6


def test_an_existing_suggestion_file_is_kept_unless_forced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    existing = tmp_path / "rc.toml"
    existing.write_text("keep me\n")
    assert main(["rc", "--once", "--write-suggestion", str(existing)]) == 2
    assert "exists: add --force" in capsys.readouterr().err
    assert existing.read_text() == "keep me\n"
    assert main(["rc", "--once", "--write-suggestion", str(existing), "--force"]) == 0
    assert existing.read_text().startswith("# bywire rc:")


def test_sim_travel_goes_with_the_simulated_transmitter_only(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["rc", "--port", "/dev/null", "--sim-travel", "50", "--once"]) == 2
    assert "--sim-travel goes with the simulated transmitter" in capsys.readouterr().err


def test_help_explains_the_calibration(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["rc", "--help"])
    assert exited.value.code == 0
    text = capsys.readouterr().out
    for words in ("positions_raw", "--write-suggestion", "never edits", "q or Ctrl-C", "--sim"):
        assert words in text


def test_the_live_view_quits_on_q_and_prints_the_suggestion(tmp_path: Path) -> None:
    """The live path end to end: the textual view on a terminal of its own (a pty), `q`."""
    master, slave = os.openpty()
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "160", "LINES": "40"}
    process = subprocess.Popen(
        [*BYWIRE, "rc", "--sim"], stdin=slave, stdout=slave, stderr=slave, env=env
    )
    os.close(slave)
    output = bytearray()
    try:
        deadline = time.monotonic() + LIMIT_S
        while b"rested at" not in output:  # the table's header: the view is up
            assert time.monotonic() < deadline, output.decode(errors="replace")[-2000:]
            output += _read(master)
        os.write(master, b"q")
        while process.poll() is None:  # read on: a full terminal would block its writes
            assert time.monotonic() < deadline, "bywire rc did not quit on q"
            output += _read(master)
        while chunk := _read(master):
            output += chunk
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        os.close(master)
    assert process.returncode == 0
    assert b"# bywire rc: RC calibration for the simulator defaults" in output


def _read(master: int) -> bytes:
    import select  # noqa: PLC0415

    ready, _, _ = select.select([master], [], [], 0.2)
    if not ready:
        return b""
    try:
        return os.read(master, 65536)
    except OSError:  # the child closed its side
        return b""
