"""The schedule table: a new line task is one row and one function, and everything else derives.

The horn is added in a child process (`tests/horn_row.py`), whose bywire loads its schedule table
from source with one more row before anything else imports it; nothing but the row and its
function (and, in a robot file, its keys) is written for it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bywire.task_table import LINE_TASKS, SCHEDULE, TASK_LINES

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def horn() -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "src")])}
    done = subprocess.run(
        [sys.executable, "-m", "tests.horn_row"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    seen: dict[str, object] = json.loads(done.stdout)
    return seen


def test_the_shipped_table_has_no_line_task_yet() -> None:
    """What the child adds is new: no row of the shipped table drives a line of its own."""
    assert "horn" not in {spec.name for spec in SCHEDULE}
    assert LINE_TASKS == ()
    assert TASK_LINES == ()


def test_a_line_task_runs_at_its_rows_rate_on_the_simulator(horn: dict[str, object]) -> None:
    assert horn["rate_hz"] == 10.0
    assert horn["runs"] == pytest.approx(30, abs=1)  # 3 s at 10 Hz
    assert horn["writes_per_100_ms"] == [1] * 9  # one write per period, no more


def test_a_line_task_drives_its_line_and_the_stop_and_safe_state_drive_it_low(
    horn: dict[str, object],
) -> None:
    """The reversing beeper sounds while driven in reverse; the operator's STOP (at 2 s)
    silences it within its period, and the run ends with the line low."""
    assert horn["sounding_at"] == {"0.45": False, "1.90": True, "2.15": False, "2.95": False}
    assert horn["sounding_at_end"] is False


def test_the_watchdogs_trip_drives_a_line_tasks_line_low_and_refuses_its_writes(
    horn: dict[str, object],
) -> None:
    assert horn["trip"] == [True, False, False]


def test_the_robot_file_names_a_line_tasks_rate_and_line(horn: dict[str, object]) -> None:
    assert horn["configured_rate_hz"] == 25.0
    assert horn["configured_line"] == ["gpiochip1", "GPIO20"]
    assert horn["round_trip"] is True
    assert horn["described"] == [
        "horn_rate_hz = 25.0",
        'horn_line = { chip = "gpiochip1", line = "GPIO20" }',
    ]


def test_a_bad_or_shared_line_task_line_is_refused_naming_its_key(
    horn: dict[str, object],
) -> None:
    refusals = horn["refusals"]
    assert isinstance(refusals, dict)
    assert "tasks.horn_line = true: expected a line name" in refusals["not_a_line"]
    assert (
        "lights.error_led and tasks.horn_line both use GPIO chip, line"
        in (refusals["error_led_line"])
    )
