"""The run summary: figures from a real short run, the STOP timing, verdicts, JSON and text."""

from __future__ import annotations

import io
import json
from dataclasses import replace

import pytest
from rich.console import Console

from bywire.canlog.write import BusTally
from bywire.command_table import COMMANDS
from bywire.config import default_sim_config
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from bywire.sim.summary import LabelledEvent, Summary, build_summary, render
from bywire.task_table import SCHEDULE

WALL_S = 0.5  # a made-up wall time: the shares and the speed-up must follow from it exactly

SCENARIO = """
name = "unit"
description = "arm, drive by RC, two bad CAN frames, STOP"
duration_s = 2.0

[[event]]
at_s = 0.2
label = "arm"
rc = { mode = "stop", gear = "forward", throttle = 0.0 }

[[event]]
at_s = 0.4
rc = { mode = "rc" }

[[event]]
at_s = 0.5
rc = { throttle = 0.6 }

[[event]]
at_s = 0.6
label = "bad CRC"
fault = "can_corrupt_crc"
count = 2

[[event]]
at_s = 1.5
label = "STOP"
rc = { mode = "stop", throttle = 0.0 }

[[expect]]
label = "moving by RC"
at_s = 1.4
mode = "rc"
speed_min_mps = 0.01

[[expect]]
label = "[safe] after STOP"
after = "STOP"
within_s = 0.110
mode = "stop"
ebrake_engaged = true
"""


def _run(duration_s: float | None = None, text: str = SCENARIO) -> tuple[SimRun, BusTally]:
    run = SimRun(default_sim_config(), parse_scenario(text, "unit.toml"), duration_s=duration_s)
    tally = BusTally()
    run.add_can_monitor(tally)
    run.run()
    return run, tally


@pytest.fixture(scope="module")
def finished() -> tuple[SimRun, BusTally]:
    return _run()


@pytest.fixture
def summary(finished: tuple[SimRun, BusTally]) -> Summary:
    run, tally = finished
    return build_summary(run, WALL_S, tally)


def test_figures_come_from_the_run(finished: tuple[SimRun, BusTally], summary: Summary) -> None:
    run, _ = finished
    assert summary.simulated_s == 2.0
    assert summary.speedup == pytest.approx(2.0 / WALL_S)
    assert summary.distance_m == run.record.samples[-1].distance_m > 0
    assert summary.top_speed_mps == run.record.top_speed_mps > 0
    assert [change.mode for change in summary.mode_changes] == ["STOP", "RC", "STOP"]
    assert 0.4 <= summary.mode_changes[1].at_s < 0.45  # times count from the start of the run


def test_task_rows_are_runs_per_simulated_second_and_time_per_wall_second(
    finished: tuple[SimRun, BusTally], summary: Summary
) -> None:
    rows = {row.name: row for row in summary.tasks}
    assert list(rows) == [spec.name for spec in SCHEDULE]  # every row of the table, in order
    for task in finished[0].runtime.tasks:
        row = rows[task.spec.name]
        assert row.rate_hz == pytest.approx(task.stats.runs / 2.0)
        assert row.rate_hz == pytest.approx(task.spec.rate_hz, rel=0.06)
        assert row.runtime_share_pct == pytest.approx(100 * task.stats.spent_s / WALL_S)
        assert row.jitter_p99_s <= row.jitter_max_s  # the percentile is a bin edge: clamped


def test_inputs_count_ibus_frames_rejected_commands_and_bus_traffic(
    finished: tuple[SimRun, BusTally], summary: Summary
) -> None:
    run, tally = finished
    inputs = summary.inputs
    assert inputs.ibus_frames == run.runtime.ibus.parser.stats.frames > 200
    # The CRC hides the counter, so the next good frame's counter looks skipped: also rejected.
    assert inputs.can_rejected["bad CRC"] == 2
    assert set(inputs.can_rejected) <= {"bad CRC", "repeated or skipped counter"}
    assert inputs.reports_sent == run.runtime.reports_sent > 0
    assert inputs.bus_frames == sum(tally.frames_by_sender.values())
    assert set(inputs.bus_frames_by_sender) == {"bywire", "hlc"}
    assert "CAN_COMMAND_REJECTED" in summary.error_flags_seen


def test_the_power_up_state_is_told_apart_from_the_faults_of_the_run(summary: Summary) -> None:
    # Before the first arming the robot is not armed and has seen no RC frame yet: not a fault.
    assert "NOT_ARMED" in summary.power_up_flags
    assert "NOT_ARMED" not in summary.error_flags_seen
    assert "RC_TIMEOUT" not in summary.error_flags_seen
    assert "before the first arming (power-up): " in _text(summary)


def test_time_to_stop_is_the_stop_events_with_its_deadline(summary: Summary) -> None:
    events = {event.label: event for event in summary.events}
    assert events["arm"].already_safe
    assert events["arm"].time_to_safe_s is None
    assert events["bad CRC"].action == "can_corrupt_crc"
    # The bad CRC did not make the robot stop, and the later STOP is not credited to it.
    assert events["bad CRC"].time_to_safe_s is None
    (stop,) = summary.stop_times
    assert stop.label == "STOP"
    assert stop.deadline_s == 0.110
    assert stop.time_to_safe_s is not None
    assert 0 < stop.time_to_safe_s <= 0.110


def test_without_a_stop_event_every_event_that_made_the_robot_safe_is_timed(
    summary: Summary,
) -> None:
    fault = LabelledEvent("lost", 1.0, "rc_link_lost", False, 0.1, 0.11)
    harmless = LabelledEvent("noise", 0.5, "ibus_garbage", False, None, None)
    already = LabelledEvent("arm", 0.2, "rc", True, None, None)
    mode_switch = LabelledEvent("stop switch", 2.0, "rc", False, 0.01, None)
    changed = replace(summary, events=(already, harmless, fault, mode_switch))
    assert changed.stop_times == [fault]


def test_every_expectation_passed(summary: Summary) -> None:
    assert [e.status for e in summary.expectations] == ["pass", "pass"]
    assert summary.expectations[1].measured_s is not None
    assert summary.passed
    assert summary.failed == []


def test_a_run_cut_short_leaves_later_expectations_not_reached_not_failed() -> None:
    run, tally = _run(duration_s=1.0)
    summary = build_summary(run, WALL_S, tally)
    assert [e.status for e in summary.expectations] == ["not reached", "not reached"]
    assert summary.passed
    assert summary.stop_times == []


def test_expectations_after_a_run_cut_short_are_not_reached() -> None:
    run, tally = _run(duration_s=1.0)  # `bywire sim --duration 1`; the scenario lasts 2 s
    summary = build_summary(run, WALL_S, tally)
    assert [e.status for e in summary.expectations] == ["not reached", "not reached"]
    assert summary.passed


def test_expectations_after_a_run_stopped_by_a_signal_are_not_reached() -> None:
    """Issue 32, defect 10: Ctrl-C (the loop asked to stop, as the signal handler does) showed
    them FAIL, where --duration showed them not reached."""
    run = SimRun(default_sim_config(), parse_scenario(SCENARIO, "unit.toml"))
    run.world.clock.call_at(1.0, run.runtime.request_stop)
    run.run()
    summary = build_summary(run, WALL_S)
    assert summary.simulated_s == pytest.approx(1.0, abs=0.011)
    assert [e.status for e in summary.expectations] == ["not reached", "not reached"]
    assert summary.passed
    console = Console(file=io.StringIO(), width=100)
    render(summary, console)
    text = console.file.getvalue()  # type: ignore[attr-defined]
    assert "0 of 2 expectations passed, 2 not reached (the run ended before them)" in text


def test_json_has_stable_keys_and_numbers(summary: Summary) -> None:
    data = json.loads(json.dumps(summary.as_json()))
    assert set(data) == {
        "scenario", "description", "simulated_s", "wall_s", "speedup", "distance_m",
        "top_speed_mps", "mode_changes", "events", "stop_times", "expectations",
        "error_flags_seen", "power_up_flags", "inputs", "tasks", "passed", "failed",
    }  # fmt: skip
    assert isinstance(data["distance_m"], float)
    assert data["mode_changes"][0] == {"at_s": 0.0, "mode": "STOP"}
    assert data["stop_times"][0]["label"] == "STOP"
    assert isinstance(data["stop_times"][0]["time_to_safe_s"], float)
    assert isinstance(data["tasks"][0]["runs"], int)
    assert data["inputs"]["can_rejected"]["bad CRC"] == 2
    assert data["passed"] is True


def _text(summary: Summary) -> str:
    buffer = io.StringIO()
    render(summary, Console(file=buffer, width=120, color_system=None))
    return buffer.getvalue()


def test_text_names_every_figure_and_keeps_brackets_in_labels(summary: Summary) -> None:
    text = _text(summary)
    assert "Scenario unit: arm, drive by RC, two bad CAN frames, STOP" in text
    assert "Modes: STOP (0.000 s) → RC (0.4" in text
    assert "Time to STOP: " in text
    assert "within 110.0 ms" in text
    assert "CAN commands rejected: 2 bad CRC" in text
    assert "[safe] after STOP" in text  # not swallowed as rich markup
    assert "2 of 2 expectations passed" in text
    for task in ("steering", "driving", "hydrobrake", "can_tx", "lights"):
        assert task in text


DOUBLED = """
name = "doubled"
description = "the computer sends five movement frames twice"
duration_s = 0.5

[[event]]
at_s = 0.1
fault = "can_doubles"
count = 5
"""


def test_frames_the_simulated_computer_could_not_send_are_shown_not_dropped(
    summary: Summary,
) -> None:
    """A doubled movement frame takes one mailbox more than the rows need: that period's last
    row's frame (LightsCommand today) is refused. The summary says so (text and JSON), and says
    nothing when none was."""
    last = COMMANDS[-1].name
    run, tally = _run(text=DOUBLED)
    doubled = build_summary(run, WALL_S, tally)
    assert doubled.inputs.hlc_refused == dict(run.world.hlc.refused) == {last: 5}
    text = _text(doubled)
    assert f"Simulated computer: 5 command frames never sent ({last} 5)" in text
    data = json.loads(json.dumps(doubled.as_json()))
    assert data["inputs"]["hlc_refused"] == {last: 5}
    assert summary.inputs.hlc_refused == {}
    assert "Simulated computer" not in _text(summary)


def test_text_names_the_failed_expectation() -> None:
    run, tally = _run(text=SCENARIO.replace("speed_min_mps = 0.01", "speed_min_mps = 25.0"))
    text = _text(build_summary(run, WALL_S, tally))
    assert "1 of 2 expectations passed" in text
    assert "FAILED: moving by RC" in text
