"""`bywire dashboard` from the command line: help, user errors as one line, the run it builds."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from bywire.cli import dashboard
from bywire.cli.main import COMMANDS, main
from bywire.dashboard.live import LiveRun
from bywire.hal.sim.clock import RealtimeClock


def test_help_says_what_it_shows_and_how_to_quit(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["dashboard", "--help"])
    assert exited.value.code == 0
    out = capsys.readouterr().out
    for option in ("--scenario", "--config", "--duration"):
        assert option in out
    assert "Figure 30" in out
    assert "q quits" in out
    assert "dashboard" in COMMANDS


def test_an_unknown_scenario_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["dashboard", "--scenario", "test-corse"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bywire dashboard: error: unknown scenario 'test-corse'")
    assert "did you mean 'test-course'?" in err
    assert err.count("\n") == 1


def test_a_missing_config_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dashboard", "--config", str(tmp_path / "none.toml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bywire dashboard: error:")
    assert err.count("\n") == 1


def test_it_runs_the_scenario_in_real_time_and_stops_the_controller_after_the_view(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    shown: list[LiveRun] = []

    def fake_view(live: LiveRun) -> None:
        assert live.running
        shown.append(live)

    monkeypatch.setattr(dashboard, "run_app", fake_view)
    args = argparse.Namespace(scenario="rc-link-lost", config=None, duration=30.0)
    assert dashboard.run(args) == 0
    (live,) = shown
    assert live.sim.scenario.name == "rc-link-lost"
    assert isinstance(live.sim.world.clock, RealtimeClock)
    assert not live.running
    assert live.feed.status == "stopped: outputs safe"


def test_default_scenario_is_the_test_course() -> None:
    parser = argparse.ArgumentParser()
    dashboard.configure(parser)
    live = dashboard.build(parser.parse_args([]))
    assert live.sim.scenario.name == "test-course"
    assert not live.running
