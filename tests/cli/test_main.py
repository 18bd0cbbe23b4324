"""The entry point: a misspelt option gets the nearest one suggested, with the sub-command's usage
(issue 32, defect 9: `bywire sim --scenaro x` got none)."""

from __future__ import annotations

import argparse
import subprocess
import sys
import threading

import pytest

from bywire.background import OWNER
from bywire.cli import main as main_module
from bywire.cli.main import main
from bywire.errors import BywireError


@pytest.mark.parametrize(
    ("argv", "suggested"),
    [
        (["sim", "--scenaro", "x"], "--scenario"),
        (["sim", "--scenaro=x"], "--scenario"),
        (["monitor", "--onse"], "--once"),
        (["dbc", "show", "--dcb", "x.dbc"], "--dbc"),  # an option of the sub-command's own
    ],
)
def test_a_misspelt_option_suggests_the_nearest(
    argv: list[str], suggested: str | None, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"bywire {argv[0]}: error: unrecognized arguments: ")
    if suggested is not None:
        assert last.endswith(f"(did you mean {suggested}?)")
        assert f"usage: bywire {argv[0]}" in err


def test_an_option_nothing_is_close_to_gets_no_guess(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sim", "--zzzzzzzz"])
    assert "did you mean" not in capsys.readouterr().err


class _Leaving:
    """A command that starts a thread and a child process through the owner and leaves them
    running, then ends as `ending` says."""

    def __init__(self, ending: BaseException | None) -> None:
        self.ending = ending
        self.release = threading.Event()
        self.thread: threading.Thread | None = None
        self.child: subprocess.Popen[bytes] | None = None

    def configure(self, parser: argparse.ArgumentParser) -> None:
        pass

    def run(self, args: argparse.Namespace) -> int:
        self.thread = OWNER.thread(self.release.wait, name="test-left", stop=self.release.set)
        self.child = OWNER.popen([sys.executable, "-c", "import time; time.sleep(60)"], name="c")
        if self.ending is not None:
            raise self.ending
        return 0


@pytest.mark.parametrize(
    ("ending", "status"),
    [(None, 0), (BywireError("refused"), 2), (KeyboardInterrupt(), 130)],
    ids=["return", "error", "ctrl-c"],
)
def test_every_way_out_of_a_command_ends_what_it_left_running(
    ending: BaseException | None, status: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 42: the owner's scope around the command ends its threads and children, newest
    first, on a return, an error and Ctrl-C alike."""
    command = _Leaving(ending)
    monkeypatch.setattr(main_module, "_load", lambda _name: command)
    assert main(["demo"]) == status
    assert command.child is not None
    assert command.child.poll() is not None  # ended (SIGTERM), not left to live on
    assert command.thread is not None
    assert not command.thread.is_alive()
