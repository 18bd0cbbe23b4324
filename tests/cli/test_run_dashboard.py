"""`bywire run --dashboard`: documented in --help, refused without a terminal, and end to end on
the stand-ins with the view on a pseudo-terminal: q or SIGTERM ends the run de-energised."""

from __future__ import annotations

import os
import pty
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.model import ControlMode, Gear
from tests.cli.test_run import LAUNCHER, LIMIT_S, _assert_de_energised
from tests.hal.linux.bench import Bench, make_bench
from tests.hal.linux.pty_rc import PtyRcLine

ESCAPES = re.compile(r"\x1b(\[[0-?]*[ -/]*[@-~]|\][^\x07]*\x07|[()][0-9A-Za-z]|[=>78])")


def test_help_documents_the_dashboard(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["run", "--help"])
    assert exited.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--dashboard" in out
    assert "live controller view" in out
    assert "q, SIGINT or SIGTERM stop the controller" in out


def test_without_a_terminal_it_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "--config", str(tmp_path / "none.toml"), "--dashboard"]) == 2
    err = capsys.readouterr().err
    assert err == "bywire run: error: --dashboard needs a terminal (stderr is not one)\n"


class Screen:
    """`bywire run --dashboard` on a bench, its terminal a pty whose output is kept as text
    (textual draws on stderr; the held log lines follow when the view has ended)."""

    def __init__(self, bench: Bench) -> None:
        config = bench.root / "robot.toml"
        config.write_text(bench.config_text())
        hlc = bench.root / "hlc"
        hlc.mkdir()
        args = ["run", "--config", str(config), "--sysfs-root", str(bench.sysfs)]
        args += ["--dev-root", str(bench.dev), "--dashboard"]
        self.master, slave = pty.openpty()
        env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "160", "LINES": "50"}
        self.process = subprocess.Popen(
            [sys.executable, str(LAUNCHER), str(hlc), bench.can_channel, "--", *args],
            stdin=slave,
            stdout=slave,
            stderr=slave,
            env=env,
            start_new_session=True,
        )
        os.close(slave)
        self._chunks: list[bytes] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                chunk = os.read(self.master, 65536)
            except OSError:
                return
            if not chunk:
                return
            self._chunks.append(chunk)

    def text(self) -> str:
        return ESCAPES.sub("", b"".join(self._chunks).decode(errors="replace"))

    def wait_for(self, text: str) -> None:
        deadline = time.monotonic() + LIMIT_S
        while text not in self.text():
            if self.process.poll() is not None:
                pytest.fail(f"bywire exited ({self.process.returncode}) before {text!r}")
            assert time.monotonic() < deadline, f"never on screen: {text!r}"
            time.sleep(0.05)

    def finish(self) -> int:
        try:
            status = self.process.wait(timeout=LIMIT_S)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()
        self._reader.join(LIMIT_S)  # the pty reads EOF (EIO) once the process has gone
        os.close(self.master)
        return status


@pytest.mark.parametrize("how", ["q", "SIGTERM"])
def test_the_view_on_the_robot_stand_ins_and_the_end_is_de_energised(
    tmp_path: Path, how: str
) -> None:
    bench = make_bench(tmp_path)
    line = PtyRcLine(bench.rc_link)
    line.transmitter.set_mode(ControlMode.STOP)
    line.transmitter.set_gear(Gear.FORWARD)
    line.start()
    try:
        screen = Screen(bench)
        screen.wait_for("error flags")
        screen.wait_for("steering")  # the task table
        if how == "q":
            os.write(screen.master, b"q")
        else:
            screen.process.send_signal(signal.SIGTERM)
        status = screen.finish()
    finally:
        line.close()
    after_view = screen.text().rsplit("bywire run: INFO", 1)[-1]
    assert status == 0, screen.text()[-2000:]
    assert "stopped; outputs de-energised" in after_view
    assert "Traceback" not in screen.text()
    _assert_de_energised(bench)
