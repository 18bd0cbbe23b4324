"""`bywire sim --record` then `bywire replay`: identical outputs exit 0, a changed steering
calibration exits 1 naming the steering output and its time, anything else exits 2."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import re
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.config import default_sim_config, describe
from bywire.hal.tape.run_record import read_record


def _main(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("replay") / "course.jsonl"
    status, out, err = _main("sim", "--duration", "5", "--record", str(path), "--json")
    assert status == 0, err or out  # the summary names the failed expectation
    assert json.loads(out)["files"]["record"] == str(path)
    return path


def _robot_toml(tmp_path: Path, max_pulse_s: float) -> Path:
    robot = default_sim_config()
    steering = dataclasses.replace(
        robot.steering, servo=dataclasses.replace(robot.steering.servo, max_pulse_s=max_pulse_s)
    )
    path = tmp_path / "changed.toml"
    path.write_text(describe(dataclasses.replace(robot, steering=steering)), encoding="utf-8")
    return path


def test_a_recorded_sim_run_replays_identically(record: Path) -> None:
    status, out, err = _main("replay", str(record))
    assert (status, err) == (0, "")
    match = re.fullmatch(r"(\d+) outputs identical \(test-course, 5 s replayed\)\n", out)
    assert match is not None
    assert int(match[1]) > 1000


def test_a_changed_steering_calibration_names_the_first_divergent_output(
    record: Path, tmp_path: Path
) -> None:
    config = _robot_toml(tmp_path, max_pulse_s=0.0019)
    status, out, _ = _main("replay", str(record), "--config", str(config))
    assert status == 1
    found = re.search(
        r"first divergence at (\d+\.\d+) s: steering_pwm recorded (\S+), replayed", out
    )
    assert found is not None, out
    assert 3.5 <= float(found[1]) < 3.6
    status, out, _ = _main("replay", str(record), "--config", str(config), "--json")
    verdict = json.loads(out)
    assert (status, verdict["identical"], verdict["divergence"]["output"]) == (
        1,
        False,
        "steering_pwm",
    )


def test_the_sim_says_where_the_record_went(tmp_path: Path) -> None:
    path = tmp_path / "short.jsonl.gz"
    status, out, _ = _main("sim", "--duration", "0.5", "--record", str(path))
    assert status in (0, 1)  # expectations after 0.5 s are not reached
    assert f"Run record: {path}" in out
    assert _main("replay", str(path))[0] == 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["replay", "{tmp}/run.blf"], "is a CAN log"),
        (["replay", "{tmp}/missing.jsonl"], "no such run record"),
        (["replay", "{tmp}/not-a-record.jsonl"], "line 1: not a valid run record"),
        (["sim", "--record", "{tmp}/no/such/dir/run.jsonl"], "does not exist"),
        (["sim", "--realtime", "--record", "{tmp}/run.jsonl"], "runs in real time"),
    ],
)
def test_user_errors_are_one_line_and_exit_2(argv: list[str], message: str, tmp_path: Path) -> None:
    (tmp_path / "not-a-record.jsonl").write_text("hello\n", encoding="utf-8")
    status, _, err = _main(*(arg.replace("{tmp}", str(tmp_path)) for arg in argv))
    assert status == 2
    assert err.count("\n") == 1
    assert message in err


def _deterministic(summary: dict[str, object]) -> dict[str, object]:
    """The summary without what the wall clock measures (the run's speed, the time each task
    took and so its budget overruns) and without the files' names."""
    tasks = [
        {k: v for k, v in row.items() if k not in ("runtime_share_pct", "budget_exceeded")}
        for row in summary["tasks"]  # type: ignore[attr-defined]
    ]
    dropped = ("wall_s", "speedup", "files", "tasks")
    return {**{k: v for k, v in summary.items() if k not in dropped}, "tasks": tasks}


def _frames(log: Path) -> list[tuple[float, str]]:
    """A candump -L log's frames with their times from the first (the log starts at the wall
    clock's time of the run, so the microseconds printed may round either way)."""
    lines = [line.split(" ", 1) for line in log.read_text(encoding="ascii").splitlines()]
    first_s = float(lines[0][0].strip("()"))
    return [(float(stamp.strip("()")) - first_s, rest) for stamp, rest in lines]


def _same_frames(a: list[tuple[float, str]], b: list[tuple[float, str]]) -> bool:
    return len(a) == len(b) and all(
        x[1] == y[1] and abs(x[0] - y[0]) <= 2e-6 for x, y in zip(a, b, strict=True)
    )


def test_record_and_mcap_change_nothing_the_run_does(tmp_path: Path) -> None:
    """Issue 32, defect 1: with --record the watchdog never tripped in dac-stall-watchdog (2 of 5
    expectations), with --mcap as well it tripped at another time on every run."""
    plain_log, files_log = tmp_path / "plain.log", tmp_path / "files.log"
    scenario = ("sim", "--scenario", "dac-stall-watchdog", "--json")
    status, plain, _ = _main(*scenario, "--log", str(plain_log))
    assert status == 0
    record, mcap = tmp_path / "run.jsonl", tmp_path / "run.mcap"
    status, with_files, _ = _main(
        *scenario, "--log", str(files_log), "--record", str(record), "--mcap", str(mcap)
    )
    assert status == 0
    assert _deterministic(json.loads(with_files)) == _deterministic(json.loads(plain))
    assert _same_frames(_frames(files_log), _frames(plain_log))  # every frame, at its time
    assert mcap.stat().st_size > 0
    outputs = len(read_record(record).outputs)
    identical = f"{outputs} outputs identical (dac-stall-watchdog, 5 s replayed)\n"
    assert _main("replay", str(record)) == (0, identical, "")
