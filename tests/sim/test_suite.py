"""`bywire sim --all`: a verdict per scenario, a bad file a failed case of its own, and a JUnit
XML report a CI system reads."""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.config import default_sim_config
from bywire.errors import ConfigError
from bywire.sim.catalog import scenario_names
from bywire.sim.suite import collect, junit_xml, run_case

ARMED = """
duration_s = 1.0
[[event]]
at_s = 0.1
rc = { mode = "stop", throttle = 0.0 }
[[event]]
at_s = 0.3
rc = { mode = "rc" }
[[expect]]
label = "armed by RC"
at_s = 0.8
mode = "{mode}"
"""


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "a-passes.toml").write_text(ARMED.replace("{mode}", "rc"))
    (tmp_path / "b-fails.toml").write_text(ARMED.replace("{mode}", "can"))
    (tmp_path / "c-bad.toml").write_text('[[event]]\nat_s = 1\nrc = { mode = "stpo" }\n')
    (tmp_path / "notes.txt").write_text("not a scenario")
    return tmp_path


def test_every_packaged_scenario_is_collected_by_default() -> None:
    assert [name for name, _, _ in collect(None)] == scenario_names()


def test_a_folder_gives_its_toml_files_in_name_order(folder: Path) -> None:
    assert [name for name, _, _ in collect(folder)] == ["a-passes", "b-fails", "c-bad"]


def test_a_folder_without_scenarios_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"no \*\.toml scenario files"):
        collect(tmp_path)


def test_each_case_gets_its_verdict_and_a_bad_file_is_an_error_of_its_own(folder: Path) -> None:
    robot = default_sim_config()
    cases = [run_case(robot, *found) for found in collect(folder)]
    assert [case.passed for case in cases] == [True, False, False]
    assert cases[1].reasons == ["armed by RC"]
    assert "event[0].rc.mode: got 'stpo'" in cases[2].reasons[0]
    report = ET.fromstring(junit_xml(cases))
    suite = report.find("testsuite")
    assert suite is not None
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("3", "1", "1")
    testcases = suite.findall("testcase")
    assert [t.get("name") for t in testcases] == ["a-passes", "b-fails", "c-bad"]
    assert testcases[0].find("failure") is None
    failure = testcases[1].find("failure")
    assert failure is not None
    assert failure.text == "armed by RC"
    assert testcases[2].find("error") is not None


def test_the_command_exits_1_writes_the_report_and_names_each_verdict(
    folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "junit.xml"
    assert main(["sim", "--all", str(folder), "--junit", str(report), "--json"]) == 1
    verdicts = json.loads(capsys.readouterr().out)
    assert verdicts["failed"] == ["b-fails", "c-bad"]
    assert ET.parse(report).getroot().tag == "testsuites"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--all", "--plot", "x.png"], "--plot: for one scenario"),
        (["--junit", "r.xml"], "--junit needs --all"),
    ],
)
def test_options_for_one_run_are_refused_with_all(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["sim", *argv]) == 2
    assert message in capsys.readouterr().err


BROKEN: dict[
    str, str | bytes
] = {  # each stopped `--all` with a traceback (or never ended) before it was checked at load
    "b-nan-duration.toml": "duration_s = nan\n",
    "c-rc-not-a-table.toml": "[[event]]\nat_s = 0.1\nrc = 5\n",
    "d-inf-during.toml": (
        '[[event]]\nat_s = 0.1\nlabel = "x"\nrc = { mode = "stop" }\n'
        '[[expect]]\nafter = "x"\nduring_s = inf\nmode = "stop"\n'
    ),
    "e-not-utf8.toml": b"name = '\xff'\n",
    "f-huge.toml": "duration_s = " + "9" * 5000 + "\n",
}


def test_all_goes_on_past_every_file_that_does_not_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "a-passes.toml").write_text(ARMED.replace("{mode}", "rc"))
    for name, content in BROKEN.items():
        path = tmp_path / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    os.mkfifo(tmp_path / "g-fifo.toml")
    (tmp_path / "h-device.toml").symlink_to("/dev/zero")
    (tmp_path / "z-passes.toml").write_text(ARMED.replace("{mode}", "rc"))
    assert main(["sim", "--all", str(tmp_path), "--json"]) == 1
    verdicts = json.loads(capsys.readouterr().out)
    assert [row["passed"] for row in verdicts["scenarios"]] == [True, *[False] * 7, True]
    for row in verdicts["scenarios"][1:-1]:
        (reason,) = row["reasons"]
        assert "\n" not in reason, reason
        assert reason.startswith(row["origin"]), reason
