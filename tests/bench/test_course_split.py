"""bench/course_split.py: the course's wall time split between its parts, and the ceiling.

Nothing here asserts how fast anything is; what is checked is that the split accounts for the
run (parts that cannot exceed the wall time, every pass counted once) and leaves the classes it
times as it found them.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

from bywire.config import default_sim_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.runtime.loop import Runtime
from bywire.sim.runner import SimRun

SCRIPT = Path(__file__).resolve().parents[2] / "bench" / "course_split.py"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("course_split", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while building
    spec.loader.exec_module(module)
    return module


def test_the_split_accounts_for_the_run_and_unwraps_what_it_timed() -> None:
    script = _script()
    originals = (Runtime._pass, Runtime._decide, VirtualClock.wait_until, SimRun._observe)
    plain, split = script.split_run(script.course(default_sim_config()))

    assert (Runtime._pass, Runtime._decide, VirtualClock.wait_until, SimRun._observe) == originals
    assert plain > 0.0
    assert split.simulated_s == 40.0  # the whole default course
    # 100 Hz decisions at least, and more passes that only read the frames between them
    assert split.deciding_passes >= 100 * 40
    assert split.reading_passes > split.deciding_passes
    parts = (split.deciding_s, split.reading_s, split.simulator_s, split.observing_s)
    assert all(part > 0.0 for part in parts)
    assert sum(parts) < split.wall_s
    assert split.ceiling > split.simulated_s / split.wall_s


def test_the_command_prints_each_part_and_the_ceiling(capsys: pytest.CaptureFixture[str]) -> None:
    assert _script().main(["--rounds", "1"]) == 0
    out = capsys.readouterr().out
    for part in ("passes that decide", "passes that only read", "simulator events", "observation"):
        assert part in out
    assert "controller ceiling:" in out


def test_campaigns_are_split_with_their_oracle_as_observation(
    capsys: pytest.CaptureFixture[str],
) -> None:
    script = _script()
    _, split = script.split_run(script.campaigns(default_sim_config(), 2))

    assert 2 * 5.0 < split.simulated_s < 2 * 20.0  # two campaigns of about ten seconds
    assert split.observing_s > 0.0  # no scenario expectations: the oracle's and the log's
    assert script.main(["--rounds", "1", "--campaigns", "1"]) == 0
    assert "as verify campaigns:" in capsys.readouterr().out
