"""`bywire sim`: the trial run end to end, its summary, plot and CAN log, and its exit status."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import pytest

from bywire.cli.main import main
from bywire.protocol import dbc
from tests.runtime.test_schedule import TABLE_1

COURSE_MODES = ["STOP", "RC", "CAN", "RC", "STOP"]

FAILING = """
name = "failing"
description = "expects CAN mode while the robot is still in STOP"
duration_s = 1.0

[[event]]
at_s = 0.2
label = "arm"
rc = { mode = "stop" }

[[expect]]
label = "driving by CAN already"
at_s = 0.5
mode = "can"

[[expect]]
label = "in STOP"
at_s = 0.6
mode = "stop"
"""


@dataclass
class Outcome:
    status: int
    out: str
    err: str


def _main(*argv: str) -> Outcome:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["sim", *argv])
    return Outcome(status, out.getvalue(), err.getvalue())


@dataclass
class CourseRun:
    outcome: Outcome
    summary: dict[str, Any]
    plot: Path
    log: Path


@pytest.fixture(scope="module")
def course(tmp_path_factory: pytest.TempPathFactory) -> CourseRun:
    """The whole test course once, as JSON, with a plot and a BLF log."""
    folder = tmp_path_factory.mktemp("course")
    plot, log = folder / "run.png", folder / "run.blf"
    outcome = _main("--json", "--plot", str(plot), "--log", str(log))
    return CourseRun(outcome, json.loads(outcome.out), plot, log)


# --- the trial run --------------------------------------------------------------------------------


def test_the_default_run_prints_the_summary_of_the_course() -> None:
    outcome = _main()
    assert outcome.status == 0, outcome.out
    text = outcome.out
    assert "Scenario test-course" in text
    assert "7 of 7 expectations passed" in text
    distance = re.search(r"Distance (\d+\.\d+) m, top speed (\d+\.\d+) m/s", text)
    assert distance is not None
    assert float(distance.group(1)) > 10
    assert float(distance.group(2)) > 1
    modes = re.search(r"Modes: (.*)", text)
    assert modes is not None
    assert re.findall(r"(STOP|RC|CAN) \(", modes.group(1)) == COURSE_MODES
    stop = re.search(r"Time to STOP: (\d+\.\d) ms after 'STOP' .* within 110\.0 ms", text)
    assert stop is not None
    assert 0 < float(stop.group(1)) <= 110
    for name, rate_hz in TABLE_1.items():
        row = re.search(rf"^{name}\s+(\d+\.\d) Hz\s+\d+\s+\d+\.\d+ %", text, flags=re.MULTILINE)
        assert row is not None, name
        assert float(row.group(1)) == pytest.approx(rate_hz, rel=0.01)
    assert outcome.err == ""  # stderr is not a terminal: no progress bar


def test_json_has_the_figures_as_numbers(course: CourseRun) -> None:
    assert course.outcome.status == 0
    summary = course.summary
    assert summary["scenario"] == "test-course"
    assert summary["simulated_s"] == 40.0
    assert isinstance(summary["distance_m"], float)
    assert summary["distance_m"] > 10
    assert isinstance(summary["top_speed_mps"], float)
    assert summary["top_speed_mps"] > 1
    assert [change["mode"] for change in summary["mode_changes"]] == COURSE_MODES
    (stop,) = summary["stop_times"]
    assert stop["label"] == "STOP"
    assert stop["deadline_s"] == 0.110
    assert 0 < stop["time_to_safe_s"] <= stop["deadline_s"]
    rates = {task["name"]: task["rate_hz"] for task in summary["tasks"]}
    assert {name: rates.get(name) for name in TABLE_1} == pytest.approx(TABLE_1, rel=0.01)
    assert all(task["overruns"] == 0 for task in summary["tasks"])
    assert {e["status"] for e in summary["expectations"]} == {"pass"}
    assert summary["passed"] is True
    assert summary["failed"] == []
    assert summary["files"] == {"plot": str(course.plot), "can_log": str(course.log)}
    assert course.outcome.err == ""


# --- plot and CAN log -----------------------------------------------------------------------------


def test_the_plot_is_a_png_with_content(course: CourseRun) -> None:
    data = course.plot.read_bytes()
    assert data.startswith(b"\x89PNG\r\n\x1a\n")
    width_px, height_px = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width_px, height_px) == (1100, 1200)
    assert len(data) > 50_000  # five panels of lines, not a blank canvas


def _check_log(path: Path, bus_frames: int) -> list[can.Message]:
    messages = list(can.LogReader(path))
    assert len(messages) == bus_frames
    ids = Counter(message.arbitration_id for message in messages)
    assert set(dbc.report_ids()) | set(dbc.command_ids()) <= set(ids)
    assert set(dbc.report_ids()) == set(range(0x200, 0x206))
    assert set(dbc.command_ids()) == {0x100, 0x101, 0x102}
    return messages


def test_the_blf_log_holds_every_frame_and_decodes_with_the_dbc(course: CourseRun) -> None:
    messages = _check_log(course.log, course.summary["inputs"]["bus_frames"])
    assert abs(messages[0].timestamp - time.time()) < 3600  # the date of the run, not 1970
    assert messages[-1].timestamp - messages[0].timestamp == pytest.approx(40.0, abs=0.05)
    database = dbc.database()

    def signals(frame_id: int, name: str) -> list[float]:
        decoded = [
            database.decode_message(m.arbitration_id, bytes(m.data), decode_choices=False)
            for m in messages
            if m.arbitration_id == frame_id
        ]
        values = [signals[name] for signals in decoded if isinstance(signals, dict)]
        return [value for value in values if isinstance(value, int | float)]

    wheels = zip(signals(0x202, "left_mps"), signals(0x202, "right_mps"), strict=True)
    top_speed_mps = max(abs(left + right) / 2 for left, right in wheels)  # the centre's speed
    assert top_speed_mps == pytest.approx(course.summary["top_speed_mps"], abs=0.05)
    assert set(signals(0x200, "control_mode")) == {0, 1, 2}  # STOP, RC and CAN reported


@pytest.mark.parametrize("suffix", [".asc", ".log"])
def test_text_logs_hold_every_frame(suffix: str, tmp_path: Path) -> None:
    path = tmp_path / f"run{suffix}"
    outcome = _main("--duration", "1", "--json", "--log", str(path))
    assert outcome.status == 0
    _check_log(path, json.loads(outcome.out)["inputs"]["bus_frames"])


def test_python_can_converts_the_blf_log_to_asc(course: CourseRun, tmp_path: Path) -> None:
    target = tmp_path / "run.asc"
    result = subprocess.run(
        [sys.executable, "-m", "can.logconvert", str(course.log), str(target)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert sum(1 for _ in can.LogReader(target)) == course.summary["inputs"]["bus_frames"]


# --- scenarios, options and exit status -----------------------------------------------------------


def test_a_scenario_file_with_a_failing_expectation_exits_1_and_names_it(tmp_path: Path) -> None:
    path = tmp_path / "failing.toml"
    path.write_text(FAILING, encoding="utf-8")
    outcome = _main("--scenario", str(path))
    assert outcome.status == 1
    assert "FAILED: driving by CAN already" in outcome.out
    assert "1 of 2 expectations passed" in outcome.out
    as_json = _main("--scenario", str(path), "--json")
    assert as_json.status == 1
    assert json.loads(as_json.out)["failed"] == ["driving by CAN already"]


def test_a_run_cut_short_passes_and_says_what_it_did_not_reach() -> None:
    outcome = _main("--duration", "2", "--json")
    assert outcome.status == 0
    summary = json.loads(outcome.out)
    assert summary["simulated_s"] == 2.0
    assert {e["status"] for e in summary["expectations"]} == {"not reached"}


def test_a_robot_configuration_file_is_used(tmp_path: Path) -> None:
    config = tmp_path / "robot.toml"
    config.write_text("[tasks]\nlights_rate_hz = 10\n", encoding="utf-8")
    outcome = _main("--config", str(config), "--duration", "4", "--json")
    assert outcome.status == 0
    rates = {task["name"]: task["rate_hz"] for task in json.loads(outcome.out)["tasks"]}
    assert rates["lights"] == pytest.approx(10, abs=0.5)
    assert rates["steering"] == pytest.approx(100, abs=1)


def test_realtime_is_paced_by_the_wall_clock() -> None:
    outcome = _main("--realtime", "--duration", "0.3", "--json")
    assert outcome.status == 0
    summary = json.loads(outcome.out)
    assert summary["simulated_s"] == pytest.approx(0.3, abs=0.02)
    assert summary["speedup"] < 1.5  # can only be slower than real time, never much faster


def test_progress_shows_on_a_terminal_but_never_with_json(monkeypatch: pytest.MonkeyPatch) -> None:
    err = io.StringIO()
    monkeypatch.setattr(err, "isatty", lambda: True)
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert main(["sim", "--duration", "1"]) == 0
    assert "1.0/1.0 s" in err.getvalue()
    assert "×" in err.getvalue()  # the speed-up factor
    json_err = io.StringIO()
    monkeypatch.setattr(json_err, "isatty", lambda: True)
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(json_err):
        assert main(["sim", "--duration", "1", "--json"]) == 0
    assert json_err.getvalue() == ""
    json.loads(out.getvalue())  # stdout holds the JSON and nothing else


class ClosedPipe(io.StringIO):
    """stdout of `bywire sim | head -1` once head has exited."""

    def __init__(self, fd: int) -> None:
        super().__init__()
        self._fd = fd

    def write(self, text: str) -> int:
        raise BrokenPipeError

    def fileno(self) -> int:
        return self._fd


def test_a_reader_that_goes_away_is_not_an_error(tmp_path: Path) -> None:
    fd = os.open(tmp_path / "stdout", os.O_WRONLY | os.O_CREAT)
    try:
        with contextlib.redirect_stdout(ClosedPipe(fd)):
            assert main(["sim", "--duration", "0.5"]) == 0  # rich on its own would exit 1
    finally:
        os.close(fd)


def test_an_unknown_scenario_exits_2_with_a_suggestion() -> None:
    outcome = _main("--scenario", "test-corse")
    assert outcome.status == 2
    assert outcome.err.count("\n") == 1
    assert "did you mean 'test-course'" in outcome.err


@pytest.mark.parametrize(
    ("option", "name", "allowed"),
    [("--plot", "run.jpg", ".png"), ("--log", "run.txt", ".blf, .asc, .log, .trc, .csv, .mf4")],
)
def test_a_bad_output_suffix_exits_2_before_running(
    option: str, name: str, allowed: str, tmp_path: Path
) -> None:
    outcome = _main(option, str(tmp_path / name))
    assert outcome.status == 2
    assert outcome.err.count("\n") == 1
    assert allowed in outcome.err
    assert outcome.out == ""  # refused before the run: no summary
    assert not (tmp_path / name).exists()


def test_list_shows_the_packaged_scenarios() -> None:
    outcome = _main("--list")
    assert outcome.status == 0
    assert re.search(r"^test-course\s+40 s\s+power up", outcome.out, flags=re.MULTILINE)
    listed = {row["name"]: row for row in json.loads(_main("--list", "--json").out)}
    assert listed["test-course"]["duration_s"] == 40.0
    assert "STOP" in listed["test-course"]["description"]


@pytest.mark.parametrize(
    ("option", "name"),
    [
        ("--plot", "run.png"),
        ("--log", "run.blf"),
        ("--record", "run.jsonl"),
        ("--mcap", "run.mcap"),
    ],
)
def test_an_existing_file_is_kept_unless_force(option: str, name: str, tmp_path: Path) -> None:
    """Issue 32, defect 10: `plot` refused to overwrite without --force, `sim` overwrote."""
    path = tmp_path / name
    path.write_bytes(b"keep me")
    refused = _main("--duration", "0.2", option, str(path))
    assert refused.status == 2
    assert refused.err == (
        f"bywire sim: error: {option} {path}: the file exists: add --force to overwrite it, or"
        " choose another file\n"
    )
    assert path.read_bytes() == b"keep me"
    forced = _main("--duration", "0.2", option, str(path), "--force")
    assert forced.status == 0, forced.err
    assert path.read_bytes() != b"keep me"


def test_speed_paces_the_run_at_n_times_real_time() -> None:
    """Issue 32: a SITL-style --speed N. The run cannot outrun its pace (the wall time is at
    least the simulated time / N) and is far from real time (6 s simulated, 1.5 s at 4x)."""
    outcome = _main("--scenario", "rc-link-lost", "--speed", "4", "--json")
    summary = json.loads(outcome.out)
    assert outcome.status == 0
    assert summary["passed"]
    assert summary["simulated_s"] == pytest.approx(6.0)
    # the wall time is measured from just after the clock starts: a millisecond of slack
    assert 6.0 / 4 - 0.001 <= summary["wall_s"] < 5.0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--speed", "5", "--realtime"], "--realtime is --speed 1"),
        (["--scenario", "loop-stall", "--speed", "5"], "stalls the loop in real time"),
        (["--speed", "2", "--record", "x.jsonl"], "runs in real time"),
    ],
)
def test_speed_refuses_what_it_cannot_do(argv: list[str], message: str) -> None:
    outcome = _main(*argv)
    assert outcome.status == 2
    assert message in outcome.err


def test_a_speed_of_zero_is_refused_by_the_parser(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sim", "--speed", "0"])
    assert "must be above 0" in capsys.readouterr().err
