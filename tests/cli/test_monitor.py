"""`bywire monitor` and `bywire sim --serve`: separate processes see the same frames."""

from __future__ import annotations

import contextlib
import os
import re
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

from bywire.cli.main import main
from bywire.model import Gear, MovementCommand
from bywire.netbus import socketcand
from bywire.protocol import dbc

SIM_S = 3.0
TIMEOUT_S = 20.0
CLIENT_ID = 0x7F0  # an id the DBC does not know: the controller ignores it, the log keeps it
CLIENT_DATA = b"\xbe\xef"
BYWIRE = [sys.executable, "-m", "bywire.cli.main"]


def _served_port(sim: subprocess.Popen[str]) -> int:
    assert sim.stderr is not None
    for line in sim.stderr:  # the sim says where it listens before the run starts
        found = re.search(r"serving the simulated bus on 127\.0\.0\.1 port (\d+)", line)
        if found:
            return int(found.group(1))
    raise AssertionError("bywire sim never said where it serves the bus")


def _talk_until_closed(bus: can.BusABC, sim: subprocess.Popen[str]) -> list[can.Message]:
    """Every frame until the sim has ended and closed the connection; sends one every 0.1 s."""
    messages: list[can.Message] = []
    deadline = time.monotonic() + TIMEOUT_S
    quiet_since: float | None = None
    next_send_s = 0.0
    while time.monotonic() < deadline:
        if sim.poll() is None and time.monotonic() > next_send_s:
            with contextlib.suppress(can.CanError, OSError):  # the sim may end meanwhile
                bus.send(
                    can.Message(arbitration_id=CLIENT_ID, data=CLIENT_DATA, is_extended_id=False)
                )
            next_send_s = time.monotonic() + 0.1
        message = bus.recv(0.05)
        if message is not None:
            messages.append(message)
            quiet_since = None
        elif sim.poll() is not None:
            quiet_since = quiet_since or time.monotonic()
            if time.monotonic() - quiet_since > 0.5:
                break
    return messages


def _is_contiguous_slice(part: list[tuple[int, bytes]], whole: list[tuple[int, bytes]]) -> bool:
    starts = [i for i, frame in enumerate(whole) if frame == part[0]]
    return any(whole[start : start + len(part)] == part for start in starts)


def test_a_sim_process_and_two_client_processes_see_the_same_frames(tmp_path: Path) -> None:
    log = tmp_path / "run.log"
    sim_args = ["sim", "--realtime", "--serve", "127.0.0.1:0", "--duration", str(SIM_S)]
    sim = subprocess.Popen(
        [*BYWIRE, *sim_args, "--log", str(log), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        port = _served_port(sim)
        assert sim.stderr is not None
        threading.Thread(target=sim.stderr.read, daemon=True).start()
        monitor = subprocess.Popen(
            [*BYWIRE, "monitor", "--port", str(port), "--duration", "1"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={"COLUMNS": "250", "PATH": ""},
        )
        client = can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="can0")
        try:
            received = _talk_until_closed(client, sim)
        finally:
            client.shutdown()
        monitor_out, monitor_err = monitor.communicate(timeout=TIMEOUT_S)
        sim.communicate(timeout=TIMEOUT_S)
    finally:
        sim.kill()
    assert sim.returncode is not None

    logged = [(m.arbitration_id, bytes(m.data)) for m in can.LogReader(log)]
    assert (CLIENT_ID, CLIENT_DATA) in logged  # the client's frame crossed the simulated bus
    frames = [(m.arbitration_id, bytes(m.data)) for m in received]
    assert len(frames) > 100
    assert {frame_id for frame_id, _ in frames} >= set(dbc.report_ids())
    # Everything from the moment the client joined to the end, in order, none lost, none
    # invented; the client's own frame is not echoed back to it.
    assert _is_contiguous_slice(frames, [frame for frame in logged if frame[0] != CLIENT_ID])

    assert monitor.returncode == 0, monitor_err
    for name in ("ModeReport", "MovementCommand", "StatusReport", "0x7F0"):
        assert name in monitor_out
    assert "control_mode=" in monitor_out


@pytest.fixture
def virtual_channel() -> Iterator[str]:
    """A python-can virtual bus with a computer sending movement commands, one repeated."""
    channel = f"bywire-monitor-{time.monotonic_ns()}"
    stop = threading.Event()

    def send() -> None:
        with can.Bus(interface="virtual", channel=channel) as bus:
            counter = 0
            while not stop.is_set():
                command = MovementCommand(0.1, 0.0, 1.0, Gear.NEUTRAL, counter % 16)
                frame_id, data = dbc.encode_command(command)
                bus.send(can.Message(arbitration_id=frame_id, data=data, is_extended_id=False))
                counter += 0 if counter == 3 else 1  # stuck at 3: repeated counters
                time.sleep(0.02)

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    yield channel
    stop.set()
    sender.join()


def test_monitor_decodes_any_python_can_interface_and_records(
    virtual_channel: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "250")
    record = tmp_path / "monitor.asc"
    args = ["-i", "virtual", "-c", virtual_channel, "--duration", "0.5", "--record", str(record)]
    assert main(["monitor", *args]) == 0
    out = capsys.readouterr().out
    assert "MovementCommand" in out
    assert "steering_norm=0.1" in out
    assert "counter" in re.sub(r"\s+", " ", out)  # the repeated counters are flagged
    recorded = list(can.LogReader(record))
    assert recorded
    assert {m.arbitration_id for m in recorded} == {0x101}


def test_piped_once_keeps_each_message_on_one_line(
    virtual_channel: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 32, defect 10: piped, the snapshot was cut or wrapped at 80 columns."""
    monkeypatch.delenv("COLUMNS", raising=False)
    args = ["-i", "virtual", "-c", virtual_channel, "--duration", "0.5", "--once"]
    assert main(["monitor", *args]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert not any("…" in line for line in lines)
    (row,) = [line for line in lines if "MovementCommand" in line]
    assert "steering_norm=0.1" in row
    assert "gear=" in row  # the last signal, on the same line


def test_monitor_without_a_server_says_how_to_start_one(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        free_port = probe.getsockname()[1]
    assert main(["monitor", "--port", str(free_port), "--once"]) == 2
    err = capsys.readouterr().err
    assert "nothing answers" in err
    assert f"--serve {free_port}" in err
    assert len(err.strip().splitlines()) == 1


def _kernel_has_socketcan() -> bool:
    try:
        socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
    except OSError:
        return False
    return True


def test_socketcan_on_a_host_without_the_interface_names_the_fix(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Issue 32, defect 9: it said only `[Errno 97] Address family not supported by protocol`."""
    assert main(["monitor", "-i", "socketcan", "-c", "bywirenone0", "--once"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "Errno" not in err
    if _kernel_has_socketcan():  # a kernel with CAN: the interface is what is missing
        assert "bywirenone0: no such network interface: plug in the adapter" in err
    else:  # this workplace's kernel, a container's, WSL's
        assert "this kernel has no SocketCAN" in err
        assert "sudo modprobe can-raw" in err


def test_monitor_refuses_a_recording_format_it_cannot_write(
    virtual_channel: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["-i", "virtual", "-c", virtual_channel, "--once", "--record", str(tmp_path / "x.txt")]
    assert main(["monitor", *args]) == 2
    assert "suffix" in capsys.readouterr().err


# --- python-can's socketcand warnings stay off the monitor's screen ---------------------------

BURST_FRAMES = 60


def _burst() -> bytes:
    """Frames in one write, longer than python-can's 1024-byte read and not cut at a frame, so
    its socketcand client finds a half frame at the end of a read ("Got incomplete message")."""
    lines = []
    for counter in range(BURST_FRAMES):
        frame_id, data = dbc.encode_command(
            MovementCommand(0.1, 0.0, 0.0, Gear.FORWARD, counter % 16)
        )
        lines.append(socketcand.frame_line(frame_id, 1_700_000_000 + counter / 50, data, False))
    text = "".join(lines)
    assert len(text) > 1024
    assert not any(len("".join(lines[:n])) == 1024 for n in range(len(lines)))
    return text.encode("ascii")


@contextlib.contextmanager
def _bursting_server() -> Iterator[int]:
    """A socketcand server on loopback: the handshake, then one burst to every client."""
    listener = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve(client: socket.socket) -> None:
        with client:
            client.sendall(b"< hi >")
            pending = ""
            while not stop.is_set():
                try:
                    chunk = client.recv(1024).decode("ascii")
                except OSError:  # the client went away without closing
                    return
                if not chunk:
                    return
                commands, pending = socketcand.split_commands(pending + chunk)
                for command in commands:
                    client.sendall(b"< ok >")
                    if command.strip() == "rawmode":
                        client.sendall(_burst())

    def accept() -> None:
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                client, _ = listener.accept()
            except TimeoutError:
                continue
            threading.Thread(target=serve, args=(client,), daemon=True).start()

    acceptor = threading.Thread(target=accept, daemon=True)
    acceptor.start()
    try:
        yield listener.getsockname()[1]
    finally:
        stop.set()
        acceptor.join()
        listener.close()


CONTROL_CLIENT = """
import sys, can
bus = can.Bus(interface="socketcand", host="127.0.0.1", port=int(sys.argv[1]), channel="can0")
received = [bus.recv(1.0) for _ in range({frames})]
bus.shutdown()
print(sum(message is not None for message in received))
"""


def test_python_cans_socketcand_warnings_never_reach_the_monitors_screen() -> None:
    with _bursting_server() as port:
        control = subprocess.run(
            [sys.executable, "-c", CONTROL_CLIENT.format(frames=BURST_FRAMES), str(port)],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            check=False,
        )
        monitor = subprocess.run(
            [*BYWIRE, "monitor", "--port", str(port), "--once"],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            check=False,
            env={**os.environ, "COLUMNS": "200"},
        )
    # A plain python-can client on the same server prints the warning: the burst provokes it.
    assert control.stdout.strip() == str(BURST_FRAMES), control.stderr
    assert "Got incomplete message" in control.stderr
    assert monitor.returncode == 0, monitor.stderr
    assert "MovementCommand" in monitor.stdout
    assert "incomplete" not in monitor.stdout + monitor.stderr
