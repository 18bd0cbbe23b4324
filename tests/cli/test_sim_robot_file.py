"""`bywire sim --config` with the reference robot's own file (config/albert.toml: backend linux,
no optional sensors, [security] off with a key file that exists only on the robot).

Issue 32: `--all` stopped at the authenticated scenario (`/etc/bywire/secoc.key: no such key
file`, exit 2, no JUnit file) and failed five scenarios that need sensors the robot does not fit
with no explanation.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import xml.etree.ElementTree as ET
from importlib import resources
from pathlib import Path

from bywire.cli.main import main

ALBERT = Path(__file__).parents[2] / "config" / "albert.toml"


def _sim(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["sim", "--config", str(ALBERT), *argv])
    return status, out.getvalue(), err.getvalue()


def _folder(tmp_path: Path, *names: str) -> Path:
    """A folder holding copies of these packaged scenarios."""
    packaged = resources.files("bywire") / "scenarios"
    tmp_path.mkdir(exist_ok=True)
    for name in names:
        with resources.as_file(packaged / f"{name}.toml") as source:
            shutil.copy(source, tmp_path / f"{name}.toml")
    return tmp_path


def test_the_robot_file_reads_no_key_file_it_does_not_use() -> None:
    assert 'key_file = "/etc/bywire/secoc.key"' in ALBERT.read_text(encoding="utf-8")
    assert not Path("/etc/bywire/secoc.key").exists()
    status, out, err = _sim("--scenario", "can-impostor-authenticated", "--json")
    assert (status, err) == (0, "")
    assert json.loads(out)["passed"] is True


def test_all_sets_aside_what_the_robot_cannot_run_and_runs_the_rest(tmp_path: Path) -> None:
    folder = _folder(tmp_path / "scenarios", "can-impostor-authenticated", "hydrobrake-failure")
    junit = tmp_path / "report.xml"
    status, out, _ = _sim("--all", str(folder), "--junit", str(junit))
    assert status == 0
    assert "PASS can-impostor-authenticated" in out
    assert "N/A  hydrobrake-failure" in out
    assert "needs the hydraulic brake's pressure sensor, which the 'linux' backend" in out
    assert "1 of 1 scenarios passed (1 not applicable to this robot)" in out
    suite = ET.parse(junit).getroot()[0]
    assert (suite.get("failures"), suite.get("errors"), suite.get("skipped")) == ("0", "0", "1")
    skipped = suite.find("testcase[@name='hydrobrake-failure']/skipped")
    assert skipped is not None
    assert "not applicable to this robot" in (skipped.get("message") or "")


def test_one_scenario_that_does_not_apply_still_runs_and_says_why_its_verdict_does_not_count() -> (
    None
):
    status, out, _ = _sim("--scenario", "steering-stuck", "--json")
    summary = json.loads(out)
    assert status == 0
    assert summary["passed"] is False  # the encoder's fault is never seen: no encoder
    assert "needs the steering encoder" in summary["not_applicable"]
    status, out, _ = _sim("--scenario", "steering-stuck")
    assert status == 0
    assert out.rstrip().splitlines()[-1].startswith("steering-stuck: not applicable to this robot")
