"""`bywire sim -i socketcan -c vcanN`: the simulated robot's CAN side on a real SocketCAN
interface, seen by can-utils' candump and driven by frames from `bywire frame` sent with
cansend and canplayer."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from bywire.model import ControlMode, ModeReport, WheelSpeedReport
from bywire.protocol import dbc
from tests.kernel import guest

TICK_S = 0.02  # the computer's 50 Hz


@pytest.fixture
def vcan() -> Iterator[guest.Vcan]:
    made = guest.Vcan()
    yield made
    made.close()


def _bywire(*args: str) -> list[str]:
    bywire = str(Path(sys.executable).with_name("bywire"))
    done = subprocess.run([bywire, *args], capture_output=True, text=True, check=True)
    return done.stdout.split()


def _frames(message: str, first: int, count: int, *options: str) -> list[str]:
    counter = str(first % dbc.COUNTER_MODULUS)
    return _bywire("frame", message, *options, "--counter", counter, "--count", str(count))


def _player_file(path: Path, channel: str) -> Path:
    """50 Hz of the three commands, as a computer sends them: 1 s held with the brake (the
    re-enable edge at 0.8 s), then 2 s of throttle; a candump -l log for canplayer."""
    movement = _frames("movement", 0, 50, "--brake", "1", "--gear", "forward")
    movement += _frames("movement", 50, 100, "--throttle", "0.4", "--gear", "forward")
    # the remote stop before used the control's counter 0; the edge comes with the brake held
    control = _frames("control", 1, 40) + _frames("control", 41, 110, "--re-enable")
    lights = _frames("lights", 0, 150)
    lines = [
        f"({index * TICK_S:.6f}) {channel} {frame}"
        for index, tick in enumerate(zip(control, movement, lights, strict=True))
        for frame in tick
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def _decoded(log: Path) -> list[object]:
    """Every report candump -L logged, decoded."""
    reports: list[object] = []
    for line in log.read_text().splitlines():
        frame = line.split()[-1]
        frame_id, _, data = frame.partition("#")
        if int(frame_id, 16) in dbc.report_ids():
            reports.append(dbc.decode_report(int(frame_id, 16), bytes.fromhex(data)))
    return reports


def test_candump_records_the_simulated_robot_and_bywire_frames_drive_it(
    tmp_path: Path, vcan: guest.Vcan
) -> None:
    bywire = str(Path(sys.executable).with_name("bywire"))
    command = [bywire, "sim", "--scenario", "teleop", "--realtime", "--duration", "60"]
    sim = subprocess.Popen(
        [*command, "-i", "socketcan", "-c", vcan.name],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    log = tmp_path / "candump.log"
    with log.open("w") as out:
        candump = subprocess.Popen(["candump", "-L", vcan.name], stdout=out)
    try:
        deadline_s = time.monotonic() + 30
        while not any(isinstance(r, ModeReport) for r in _decoded(log)):
            assert sim.poll() is None, sim.communicate()[1]
            assert time.monotonic() < deadline_s, "no report from the simulated robot on vcan"
            time.sleep(0.1)
        time.sleep(1.0)  # the transmitter has selected CAN mode (teleop scenario, 0.5 s)
        stop = _bywire("frame", "control", "--remote-stop", "--counter", "0")[0]
        guest.run("cansend", vcan.name, stop)  # one frame: a remote stop passes every filter
        time.sleep(0.3)
        assert any(isinstance(r, ModeReport) and r.stop_latched for r in _decoded(log)[-12:])
        player = _player_file(tmp_path / "drive.log", vcan.name)
        stopped = len(_decoded(log))
        guest.run("canplayer", "-I", str(player))
        driven = _decoded(log)[stopped:]
    finally:
        candump.terminate()
        candump.wait()
        sim.terminate()
        sim.wait(timeout=30)
    modes = [r for r in driven if isinstance(r, ModeReport)]
    speeds = [r for r in driven if isinstance(r, WheelSpeedReport)]
    assert len(modes) > 100  # 50 Hz for the 3 s the frames were played
    assert any(r.control_mode is ControlMode.CAN and not r.stop_latched for r in modes)
    assert max(speed.left_mps for speed in speeds) > 0.2  # re-enabled and driven by them
