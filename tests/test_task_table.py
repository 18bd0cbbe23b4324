"""The schedule table: a new line task is one row and one function, and everything else derives.

The beeper is added in a child process (`tests/beeper_row.py`), whose bywire loads its schedule
table from source with one more row before anything else imports it; nothing but the row and its
function (and, in a robot file, its keys) is written for it.
"""

from __future__ import annotations

import pytest

from bywire.task_table import TASK_LINES, TASK_NAMES
from tests.row_child import observed


@pytest.fixture(scope="module")
def beeper() -> dict[str, object]:
    return observed("tests.beeper_row")


def test_the_childs_row_is_new() -> None:
    """What the child adds is no row of the shipped table, nor a line of it."""
    assert "beeper" not in TASK_NAMES
    assert "beeper" not in TASK_LINES


def test_a_line_task_runs_at_its_rows_rate_on_the_simulator(beeper: dict[str, object]) -> None:
    assert beeper["rate_hz"] == 10.0
    assert beeper["runs"] == pytest.approx(30, abs=1)  # 3 s at 10 Hz
    assert beeper["writes_per_100_ms"] == [1] * 9  # one write per period, no more


def test_a_line_task_drives_its_line_and_the_stop_and_safe_state_drive_it_low(
    beeper: dict[str, object],
) -> None:
    """The reversing beeper sounds while driven in reverse; the operator's STOP (at 2 s)
    silences it within its period, and the run ends with the line low."""
    assert beeper["sounding_at"] == {"0.45": False, "1.90": True, "2.15": False, "2.95": False}
    assert beeper["sounding_at_end"] is False


def test_the_watchdogs_trip_drives_a_line_tasks_line_low_and_refuses_its_writes(
    beeper: dict[str, object],
) -> None:
    assert beeper["trip"] == [True, False, False]


def test_the_robot_file_names_a_line_tasks_rate_and_line(beeper: dict[str, object]) -> None:
    assert beeper["configured_rate_hz"] == 25.0
    assert beeper["configured_line"] == ["gpiochip1", "GPIO20"]
    assert beeper["round_trip"] is True
    assert beeper["described"] == [
        "beeper_rate_hz = 25.0",
        'beeper_line = { chip = "gpiochip1", line = "GPIO20" }',
    ]


def test_a_bad_or_shared_line_task_line_is_refused_naming_its_key(
    beeper: dict[str, object],
) -> None:
    refusals = beeper["refusals"]
    assert isinstance(refusals, dict)
    assert "tasks.beeper_line = true: expected a line name" in refusals["not_a_line"]
    assert (
        "lights.error_led and tasks.beeper_line both use GPIO chip, line"
        in (refusals["error_led_line"])
    )
