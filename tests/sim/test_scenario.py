"""Scenario files: parsing, sorting, and refusals that name the key and what is allowed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.errors import ConfigError
from bywire.sim.scenario import load_scenario, parse_scenario

GOOD = """
name = "demo"
duration_s = 5.0

[[event]]
at_s = 2.0
label = "lost"
fault = "rc_link_lost"

[[event]]
at_s = 0.5
rc = { mode = "stop" }

[[event]]
at_s = 1.0
hlc = { throttle = 0.3, gear = "forward" }

[[expect]]
after = "lost"
within_s = 0.11
mode = "stop"
throttle_volts_max = 0.0

[[expect]]
at_s = 1.5
speed_min_mps = 0.1
"""


def test_a_good_scenario_parses_with_events_in_time_order() -> None:
    scenario = parse_scenario(GOOD, "demo.toml")
    assert scenario.name == "demo"
    assert scenario.duration_s == 5.0
    assert [event.at_s for event in scenario.events] == [0.5, 1.0, 2.0]
    assert scenario.events[2].kind == "fault"
    assert scenario.events[2].values["fault"] == "rc_link_lost"
    assert scenario.events[1].values == {"throttle": 0.3, "gear": "forward"}
    first, second = scenario.expectations
    assert (first.after, first.within_s, first.conditions["mode"]) == ("lost", 0.11, "stop")
    assert second.at_s == 1.5
    assert "within 110 ms of 'lost'" in first.describe()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[[event]]\nat_s = 1\nfault = 'rc_lnk_lost'", "did you mean 'rc_link_lost'"),
        ("[[event]]\nat_s = -1\nfault = 'rc_link_lost'", "event[0].at_s"),
        ("[[event]]\nat_s = 1", "needs exactly one of"),
        ("[[event]]\nat_s = 1\nrc = { mode = 'rc', throtle = 1 }", "event[0].rc.throtle"),
        ("[[expect]]\nat_s = 1", "needs at least one condition"),
        ("[[expect]]\nafter = 'nothing'\nwithin_s = 0.1\nmode = 'stop'", "no event is labelled"),
        ("duraton_s = 3", "did you mean 'duration_s'"),
        ("name = ", "not valid TOML"),
        ("needs_sensors = ['wheel_speeds']", "did you mean 'wheel_speed'"),
        ("needs_sensors = 'wheel_speed'", "needs_sensors: must be a list"),
    ],
)
def test_bad_scenarios_are_refused_naming_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace("[", r"\[")):
        parse_scenario(text, "bad.toml")


EVENT = "[[event]]\nat_s = 1\n"
# (TOML, what the one-line refusal must say: the key, the value, what is allowed)
BAD_VALUES = [
    (EVENT + "rc = { mode = 'stpo' }", "event[0].rc.mode: got 'stpo'; allowed: one of \"stop\""),
    (EVENT + "rc = { gear = 'fwd' }", "event[0].rc.gear: got 'fwd'; allowed: one of \"forward\""),
    (EVENT + "hlc = { throttle = 'half' }", "event[0].hlc.throttle: got 'half'; allowed: a number"),
    (
        EVENT + "fault = 'ibus_corrupt'\ncount = 'many'",
        "event[0].count: got 'many'; allowed: a whole",
    ),
    (
        EVENT + "rc = { throttle = 1.7 }",
        "event[0].rc.throttle: got 1.7; allowed: a number in -1..1",
    ),
    (EVENT + "rc = { steering = -3 }", "event[0].rc.steering: got -3; allowed: a number in -1..1"),
    (EVENT + "hlc_control = { remote_stop = 1 }", "remote_stop: got 1; allowed: true or false"),
    ("[[expect]]\nat_s = 1\nmode = 'drive'", "expect[0].mode: got 'drive'; allowed: one of"),
    (EVENT + "world = { grade = -0.5 }", "event[0].world.grade: got -0.5; allowed: a number in"),
    (
        "duration_s = 5\n" + EVENT.replace("1", "6") + "rc = { mode = 'rc' }",
        "event[0].at_s: 6 s is after",
    ),
    ("duration_s = 5\n[[expect]]\nat_s = 7\nmode = 'rc'", "expect[0].at_s: 7 s is after the end"),
]


@pytest.mark.parametrize(("text", "message"), BAD_VALUES)
def test_bad_values_are_refused_at_load_naming_key_value_and_range(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        parse_scenario(text, "bad.toml")


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nothing\.toml"):
        load_scenario(tmp_path / "nothing.toml")


def test_a_loop_stall_needs_real_time() -> None:
    text = "[[event]]\nat_s = 1\nfault = 'loop_stall'\nstall_s = 0.3"
    with pytest.raises(ConfigError, match="realtime = true"):
        parse_scenario(text, "stall.toml")
    scenario = parse_scenario("realtime = true\n" + text, "stall.toml")
    assert scenario.realtime
    assert scenario.events[0].values["stall_s"] == 0.3


def test_a_bad_value_stops_bywire_sim_before_the_run_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("duration_s = 2\n[[event]]\nat_s = 1\nrc = { mode = 'stpo' }\n")
    assert main(["sim", "--scenario", str(path)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert "event[0].rc.mode: got 'stpo'" in error
    assert "Traceback" not in error
