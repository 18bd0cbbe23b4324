"""`bywire sim --realtime` with telemetry: the writer is running before the robot's clock starts,
so the controller's first pass (and the scenario's first events) are not late by its start."""

from __future__ import annotations

import contextlib
import io
import time
from pathlib import Path
from typing import Any, ClassVar

import pytest

from bywire.cli import sim as sim_command
from bywire.cli.main import main
from bywire.sim.runner import SimRun
from bywire.telemetry import feed
from bywire.telemetry.writer_process import WriterProcess

SLOW_START_S = 0.5  # a writer that takes this long to start (a loaded machine takes seconds)


class FirstPass(SimRun):
    """A SimRun that notes when the controller's first pass came, from the run's start."""

    built: ClassVar[list[FirstPass]] = []

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.first_pass_s: float | None = None
        self.runtime.on_cycle.append(self._seen)
        FirstPass.built.append(self)

    def _seen(self, now: float) -> None:
        if self.first_pass_s is None:
            self.first_pass_s = now - self.started_at


def test_the_first_pass_is_not_late_by_the_telemetry_writers_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    class SlowWriter(WriterProcess):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            time.sleep(SLOW_START_S)
            super().__init__(*args, **kwargs)

    FirstPass.built = []
    monkeypatch.setattr(feed, "WriterProcess", SlowWriter)
    monkeypatch.setattr(sim_command, "SimRun", FirstPass)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        status = main(
            ["sim", "--realtime", "--duration", "1", "--mcap", str(tmp_path / "run.mcap")]
        )
    assert status == 0
    (run,) = FirstPass.built
    assert run.first_pass_s is not None
    # Before the fix the first pass came after the writer's start: at least SLOW_START_S late.
    assert run.first_pass_s < SLOW_START_S / 2
