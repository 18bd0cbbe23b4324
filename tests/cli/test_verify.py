"""`bywire verify` from the command line: the default budget is clean on the default robot, the
same seed gives the same run on any number of processes, an unsafe configuration is reported
before anything runs, and a failure is written where `bywire sim --scenario` replays it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import dask
import psutil
import pytest
from distributed import Client
from rich.console import Console

from bywire.cli import verify
from bywire.cli.main import main
from bywire.config import RobotConfig, default_sim_config, parse_config, sections
from bywire.config.reader import Interval, KeyRead
from bywire.model import ControlMode
from bywire.sim.verify import engine
from bywire.sim.verify.campaign import Step
from bywire.sim.verify.draw_bridge import is_bridge_campaign
from bywire.sim.verify.engine import CampaignJob, Outcome, run_campaign
from bywire.sim.verify.oracle import INVARIANTS
from bywire.sim.verify.oracle.invariants import BRIDGE_INVARIANTS, OUTPUT_INVARIANTS
from bywire.sim.verify.robots import Schema, dotted, draw_robot, keys_needed
from bywire.sim.verify.supervisor_check import MONITOR_CAUSES, TRANSITIONS, transitions_naming
from tests.sim.verify.cluster_plugins import CrashAt, FirstResult, their_cluster
from tests.system.old_bugs import OLD_BUGS

SIM = Path(__file__).resolve().parents[2] / "src" / "bywire" / "defaults" / "sim.toml"


def _verify(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict[str, object]]:
    status = main(["verify", "--json", *args])
    output = capsys.readouterr().out
    return status, json.loads(output)


@pytest.mark.long
def test_the_default_budget_on_the_default_robot_is_clean(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    status, summary = _verify(capsys, "--jobs", "2", "--out", str(tmp_path))
    with capsys.disabled():
        print(
            f"\nbywire verify: {summary['campaigns']} campaigns, {summary['simulated_s']} s"
            f" simulated in {summary['wall_s']} s, transitions {summary['transitions']}"
        )
    assert status == 0
    assert summary["campaigns"] == 200
    assert summary["violations"] == dict.fromkeys(INVARIANTS, 0)
    assert summary["failures"] == []
    assert list(tmp_path.iterdir()) == []  # nothing written when clean
    transitions = summary["transitions"]
    assert isinstance(transitions, dict)
    assert transitions["of"] == len(TRANSITIONS)
    # Every row of the transition table, the clearing ones included: those need a fault to end
    # and the right source to re-arm, which the campaigns' episodes provide (sim/verify/draw.py).
    assert transitions["exercised"] == len(TRANSITIONS)
    assert transitions["never"] == []
    assert transitions["cannot_happen"] == []  # the simulated robot has every sensor


def test_on_a_robot_without_sensors_the_monitor_rows_cannot_happen_rather_than_never_did(
    capsys: pytest.CaptureFixture[str],
) -> None:
    robot = Path(__file__).parents[2] / "config" / "albert.toml"  # backend "linux": no sensors
    status, summary = _verify(
        capsys, "--config", str(robot), "--budget", "2", "--campaign-s", "2", "--jobs", "1"
    )
    assert status == 0
    transitions = summary["transitions"]
    assert isinstance(transitions, dict)
    cannot = transitions_naming(MONITOR_CAUSES)
    assert transitions["cannot_happen"] == list(cannot)
    assert transitions["of"] == len(TRANSITIONS) - len(cannot)
    assert not set(cannot) & set(transitions["never"])
    assert transitions["cannot_happen_but_taken"] == []
    assert transitions["exercised"] + len(transitions["never"]) == transitions["of"]
    assert main(["verify", "--config", str(robot), "--budget", "1", "--campaign-s", "1"]) == 0
    assert "8 more cannot happen on this robot" in capsys.readouterr().out


def test_the_configuration_section_states_what_each_timeout_buys(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    # Issue 41: a file may choose 1 s timeouts; verify shows the distance they cost at top speed.
    robot = tmp_path / "robot.toml"
    robot.write_text('backend = "sim"\n[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 1.0\n')
    args = ("--config", str(robot), "--budget", "1", "--campaign-s", "1", "--jobs", "1")
    status, summary = _verify(capsys, *args)
    assert status == 0
    configuration = summary["configuration"]
    assert isinstance(configuration, dict)
    rows = {row["key"]: row["distance_m"] for row in configuration["loss_distances"]}
    assert rows == {
        "timeouts.rc_timeout_s": 3.03,  # (1 s + one 10 ms period) at 3 m/s
        "timeouts.can_command_timeout_s": 0.33,
        "timeouts.watchdog_s": 3.0,
    }
    assert main(["verify", *args, "--out", str(tmp_path)]) == 0
    text = " ".join(capsys.readouterr().out.split())  # as the console wrapped it, unwrapped
    assert "configuration: what each timeout buys" in text
    assert (
        "(timeouts.rc_timeout_s = 1 s): the stop begins within 1.01 s, after up to 3.03 m" in text
    )


@pytest.mark.long
def test_the_same_seed_gives_the_same_run_on_any_number_of_processes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    runs = [
        _verify(capsys, "--budget", "4", "--campaign-s", "3", "--seed", "9", "--jobs", jobs)[1]
        for jobs in ("1", "2")
    ]
    keys = ("campaigns", "simulated_s", "events_injected", "passes_checked", "transitions")
    assert {key: runs[0][key] for key in keys} == {key: runs[1][key] for key in keys}
    other = _verify(capsys, "--budget", "4", "--campaign-s", "3", "--seed", "10", "--jobs", "1")
    assert other[1]["events_injected"] != runs[0]["events_injected"]


def test_an_unsafe_configuration_is_refused_at_load_naming_the_deadline(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text("[timeouts]\ncan_command_timeout_s = 0.5\nwatchdog_s = 0.2\n")
    status = main(["verify", "--config", str(robot)])
    error = capsys.readouterr().err
    assert status == 2
    assert "timeouts.can_command_timeout_s" in error
    assert "timeouts.watchdog_s" in error
    assert "breaks the deadline" in error


@pytest.mark.parametrize("bad", [["--budget", "0"], ["--jobs", "x"], ["--seed", "-1"]])
def test_bad_arguments_are_refused(bad: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as caught:
        main(["verify", *bad])
    assert caught.value.code == 2
    assert bad[0] in capsys.readouterr().err


def test_a_failure_is_shrunk_and_written_as_a_scenario_sim_replays(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    OLD_BUGS["row_3_a_refused_arming_is_remembered"](monkeypatch)
    status, summary = _verify(  # seed 3 finds it at campaign 2 (seed 0 only at its 28)
        capsys, "--budget", "3", "--jobs", "1", "--seed", "3", "--out", str(tmp_path)
    )
    assert status == 1
    failures = summary["failures"]
    assert isinstance(failures, list)
    assert failures
    written = Path(failures[0]["scenario"])
    assert written.parent == tmp_path
    text = written.read_text()
    assert text.startswith("# Found by `bywire verify --seed 3`")
    assert "Replay: bywire sim --scenario" in text
    assert [failure["fails_on_replay"] for failure in failures] == [True] * len(failures)
    assert main(["sim", "--scenario", str(written), "--json"]) == 1


INTERRUPTED_AFTER = 4
"""Campaigns that end before the Ctrl-C: seed 3 breaks row 3 at its campaign 2 (above)."""


def test_ctrl_c_after_a_violation_still_summarises_it_and_writes_its_scenario(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A long search interrupted once it has found something keeps the finding: the campaigns
    stop, the violation is shrunk and written, the summary says the run is incomplete, and the
    status is Ctrl-C's. Before, the KeyboardInterrupt ended it in one line, the finding lost."""
    OLD_BUGS["row_3_a_refused_arming_is_remembered"](monkeypatch)
    added = 0
    add = verify.Tally.add

    def then_ctrl_c(tally: verify.Tally, outcome: Any) -> None:
        nonlocal added
        add(tally, outcome)
        added += 1
        if added == INTERRUPTED_AFTER:
            os.kill(os.getpid(), signal.SIGINT)  # the terminal's Ctrl-C, to this process

    monkeypatch.setattr(verify.Tally, "add", then_ctrl_c)
    status, summary = _verify(
        capsys, "--budget", "200", "--jobs", "1", "--seed", "3", "--out", str(tmp_path)
    )
    assert status == 130
    assert summary["interrupted"] == "Ctrl-C"
    assert summary["stopped"] == "interrupted by Ctrl-C"
    campaigns = summary["campaigns"]
    assert isinstance(campaigns, int)
    assert INTERRUPTED_AFTER <= campaigns < 200
    failures = summary["failures"]
    assert isinstance(failures, list)
    assert failures
    assert [failure["fails_on_replay"] for failure in failures] == [True] * len(failures)
    assert Path(failures[0]["scenario"]).parent == tmp_path


def test_sigterm_while_shrinking_still_summarises_and_names_what_was_left_unshrunk(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The campaigns done, a SIGTERM (a batch scheduler's limit) arrives while the violation is
    shrunk: the summary still comes, with the violation, its campaign and how to find it
    again, and the status is SIGTERM's. Before, it ended in main's KeyboardInterrupt: exit
    130, no summary."""
    OLD_BUGS["row_3_a_refused_arming_is_remembered"](monkeypatch)

    def terminated_while_shrinking(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGTERM)  # to this process, whose verify takes it
        time.sleep(1.0)  # the handler raises before this ends
        raise AssertionError("SIGTERM was not taken")

    monkeypatch.setattr(verify, "shrink_failure", terminated_while_shrinking)
    status, summary = _verify(
        capsys, "--budget", "3", "--jobs", "1", "--seed", "3", "--out", str(tmp_path)
    )
    assert status == 143
    assert (summary["interrupted"], summary["campaigns"]) == ("SIGTERM", 3)
    assert summary["stopped"] == "interrupted by SIGTERM while shrinking"
    assert summary["failures"] == []
    unshrunk = summary["unshrunk"]
    assert isinstance(unshrunk, list)
    assert unshrunk
    assert {k: unshrunk[0][k] for k in ("seed", "campaign")} == {"seed": 3, "campaign": 2}
    text = verify._unshrunk_text(unshrunk[0])
    assert "--seed 3 --budget 3 runs it again" in text


def test_sigterm_ends_a_run_summarised_with_its_status_and_leaves_nothing_running(
    tmp_path: Path,
) -> None:
    """SIGTERM to verify alone (a batch scheduler's time limit, `timeout`): the run ends as
    after Ctrl-C, with the summary of what ran on stdout, exit 143, nothing on stderr, and no
    worker left. Before, it died at once: no summary, the forked workers left to notice."""
    output = _terminated(["--budget", "400", "--campaign-s", "5", "--jobs", "2"], tmp_path)
    summary = json.loads(output)
    assert summary["interrupted"] == "SIGTERM"
    assert summary["campaigns"] < 400


def test_sigterm_ends_a_draw_summarising_the_files_so_far(tmp_path: Path) -> None:
    output = _terminated(
        ["--draw-robots", "3", "--budget", "300", "--campaign-s", "5", "--jobs", "2"], tmp_path
    )
    result = json.loads(output)
    assert result["interrupted"] == "SIGTERM"
    assert result["files_verified"] == 1
    [entry] = result["files"]
    assert entry["interrupted"] == "SIGTERM"
    assert entry["campaigns"] < 100


def _terminated(arguments: list[str], tmp_path: Path) -> str:
    """`bywire verify --json` with `arguments`, sent SIGTERM (it alone) once both its workers
    are up: exit 143, nothing on stderr, and its whole group gone; its stdout."""
    command = [sys.executable, "-m", "bywire.cli.main", "verify", "--json", *arguments]
    process = subprocess.Popen(
        [*command, "--out", str(tmp_path)],
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        verify_process = psutil.Process(process.pid)
        assert _until(
            lambda: sum(map(_ignores_sigint, verify_process.children(recursive=True))) == 2
        )
        process.terminate()
        output, error = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert (process.returncode, error.decode()) == (143, "")
    assert _until(lambda: not _group_alive(process.pid))
    return output.decode()


def test_a_duration_runs_campaigns_until_the_time_is_up(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, summary = _verify(capsys, "--duration", "1", "--campaign-s", "1", "--jobs", "1")
    assert status == 0
    assert isinstance(summary["campaigns"], int)
    assert summary["campaigns"] >= 1


def test_bridge_campaigns_run_and_are_judged_in_a_small_budget(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """CI-sized: of seed 21's first five campaigns four are bridge campaigns (the ROS 2 bridge as
    the computer); they run, and are judged on H1..H11 and on the bridge's B1..B3."""
    status, summary = _verify(
        capsys,
        *("--budget", "5", "--campaign-s", "4", "--seed", "21", "--jobs", "1"),
        *("--out", str(tmp_path)),
    )
    bridge = [index for index in range(5) if is_bridge_campaign(21, index)]
    assert summary["bridge_campaigns"] == len(bridge) == 4
    passes = summary["passes_checked"]
    assert isinstance(passes, int)
    assert passes > 0
    # every pass is judged on the output invariants, a bridge campaign's on three more
    checks = summary["invariant_checks"]
    assert isinstance(checks, int)
    outputs, bridges = len(OUTPUT_INVARIANTS), len(BRIDGE_INVARIANTS)
    assert (outputs, bridges) == (11, 3)
    assert outputs * passes < checks <= (outputs + bridges) * passes
    violations = summary["violations"]
    assert isinstance(violations, dict)
    assert set(violations) == {*(f"H{n}" for n in range(1, 12)), "B1", "B2", "B3"}
    assert (status, violations) == (0, dict.fromkeys(INVARIANTS, 0))
    assert "(1 with the ROS 2 bridge as the computer)" in _text(capsys)  # of two


def _text(capsys: pytest.CaptureFixture[str]) -> str:
    main(["verify", "--budget", "2", "--campaign-s", "2", "--seed", "21", "--jobs", "1"])
    return capsys.readouterr().out


# --- --draw-robots: is any file this loader accepts unsafe? --------------------------------------


def _drawn_run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict[str, Any]]:
    status = main(["verify", "--json", "--jobs", "1", *args])
    return status, json.loads(capsys.readouterr().out)


def test_a_small_draw_verifies_each_file_drawn_to_the_edges_of_the_loaders_ranges(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """The CI-sized search: 3 files, 5 campaigns each."""
    status, result = _drawn_run(
        capsys, "--draw-robots", "3", "--budget", "15", "--seed", "0", "--campaign-s", "2",
        "--out", str(tmp_path),
    )  # fmt: skip
    assert status == (1 if result["violating_files"] else 0)
    assert (result["files_verified"], result["campaigns"], result["interrupted"]) == (3, 15, None)
    assert "backend" in result["keys_kept"]
    assert result["keys_drawn"] > 70
    assert result["files_refused"] >= 1
    assert result["refusals_repaired"]
    schema = {dotted(read.parts): read for read in Schema.of(SIM.read_text()).keys}
    texts = set()
    for entry in result["files"]:
        assert entry["campaigns"] == 5
        path = Path(entry["file"])
        assert path.parent == tmp_path
        text = path.read_text()
        texts.add(text)
        robot = parse_config(text, str(path))  # every drawn file loads
        assert robot.backend == "sim"
        changed = entry["changed"]
        assert len(changed) >= 30
        for key, (base, new) in changed.items():
            assert f"#   {key} = " in text  # the file says which keys differ
            assert schema[key].value == (tuple(base) if isinstance(base, list) else base)
            assert new != base
        at_an_end = [key for key, (_base, new) in changed.items() if _at_an_end(schema[key], new)]
        assert len(at_an_end) >= 15, at_an_end
        assert set(entry["violations"]) == {f["invariant"] for f in entry["failures"]}
    assert len(texts) == 3


def _at_an_end(read: KeyRead, value: object) -> bool:
    allowed = read.allowed
    if isinstance(allowed, range):
        values = value if isinstance(value, list) else [value]
        return allowed.start in values or allowed[-1] in values
    if isinstance(allowed, Interval):
        assert isinstance(value, float | int)
        near = (allowed.high - allowed.low) * 1e-3
        return value - allowed.low <= near or allowed.high - value <= near
    return read.kind == "flag"


PLANTED_SEED = 93
"""A seed whose file 1 draws `sim.rc_frame_period_s` at the planted 1 ms end and whose first
campaign of 1.5 s breaks H1 on it (found once by drawing seeds; the test asserts both)."""
OTHER_KEYS_TRIED = 3


def test_a_planted_unsafe_range_is_found_with_the_key_it_needs(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A loader that accepts the simulated receiver's frame period down to 1 ms again (row 58:
    faster than the IBUS line carries): the drawer reads the widened range from the loader
    itself, draws its new end, and verify finds the stale frames' late stop end to end, shrunk
    to a scenario `bywire sim` replays, naming `sim.rc_frame_period_s` as the key it needs. The
    key search runs on the planted key and a few other drawn keys (on all ~60 it is the cost of
    this test; `tests/sim/verify/test_robots.py` checks it on a pure case)."""
    monkeypatch.setattr(sections, "RC_FRAME_PERIOD_S", Interval(0.001, 0.1, "s"))
    drawn = draw_robot(Schema.of(SIM.read_text()), PLANTED_SEED, 1)
    assert drawn.changed["sim.rc_frame_period_s"][1] == 0.001  # the drawer hits the planted end
    searched: list[dict[str, object]] = []

    def among_a_few(
        schema: Schema, changed: dict[str, object], fails: Callable[[RobotConfig], bool]
    ) -> dict[str, object]:
        others = [key for key in changed if key != "sim.rc_frame_period_s"][:OTHER_KEYS_TRIED]
        few = {key: changed[key] for key in ("sim.rc_frame_period_s", *others)}
        searched.append(few)
        return keys_needed(schema, few, fails)

    monkeypatch.setattr(verify, "keys_needed", among_a_few)
    status, result = _drawn_run(
        capsys, "--draw-robots", "1", "--budget", "1", "--campaign-s", "1.5",
        "--seed", str(PLANTED_SEED), "--out", str(tmp_path),
    )  # fmt: skip
    [entry] = result["files"]
    assert status == 1
    assert result["violating_files"] == [entry["file"]]
    assert entry["changed"]["sim.rc_frame_period_s"][1] == 0.001
    [failure] = [f for f in entry["failures"] if f["invariant"] == "H1"]
    assert len(searched[0]) == 1 + OTHER_KEYS_TRIED
    assert failure["keys_needed"] == {"sim.rc_frame_period_s": 0.001}  # the others went back
    assert failure["replays"]
    scenario, robot = Path(failure["scenario"]), Path(failure["robot"])
    assert main(["sim", "--scenario", str(scenario), "--config", str(robot), "--json"]) == 1
    capsys.readouterr()


def test_ctrl_c_while_a_drawn_files_keys_are_searched_keeps_the_file_and_its_violation(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The planted file above, interrupted once its campaigns found the violation, in the
    search for the keys it needs: the file is in the summary, violating, its failure with its
    scenario and no keys (unsearched). Before, the file was dropped: 0 files, 0 campaigns."""
    monkeypatch.setattr(sections, "RC_FRAME_PERIOD_S", Interval(0.001, 0.1, "s"))

    def ctrl_c(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1.0)
        raise AssertionError("Ctrl-C was not taken")

    monkeypatch.setattr(verify, "keys_needed", ctrl_c)
    status, result = _drawn_run(
        capsys, "--draw-robots", "2", "--budget", "2", "--campaign-s", "1.5",
        "--seed", str(PLANTED_SEED), "--out", str(tmp_path),
    )  # fmt: skip
    assert status == 130
    assert (result["interrupted"], result["files_verified"]) == ("Ctrl-C", 1)
    [entry] = result["files"]
    assert result["violating_files"] == [entry["file"]]
    assert entry["interrupted"] == "Ctrl-C"
    [failure] = [f for f in entry["failures"] if f["invariant"] == "H1"]
    assert failure["keys_needed"] is None
    assert Path(failure["scenario"]).exists()


def test_draw_robots_takes_a_budget_not_a_duration(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--draw-robots", "2", "--duration", "5"]) == 2
    assert "--draw-robots takes --budget, not --duration" in capsys.readouterr().err


def test_the_same_seed_draws_and_runs_the_same_on_any_number_of_processes(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    runs = []
    for jobs in ("1", "2"):
        out = tmp_path / jobs
        main(["verify", "--json", "--draw-robots", "2", "--budget", "4", "--campaign-s", "2",
              "--seed", "3", "--jobs", jobs, "--out", str(out)])  # fmt: skip
        result = json.loads(capsys.readouterr().out)
        files = [Path(entry["file"]).read_text() for entry in result["files"]]
        verdicts = [(e["campaigns"], e["violations"], e["changed"]) for e in result["files"]]
        runs.append((files, verdicts))
    assert runs[0] == runs[1]


# --- --cluster: the campaigns on a Dask cluster (a local one, on 127.0.0.1) ---------------------

WHERE = ("jobs", "cluster", "wall_s", "campaigns_per_minute", "speed_up")  # how, not what


def _what(summary: dict[str, object]) -> dict[str, object]:
    return {key: value for key, value in summary.items() if key not in WHERE}


def _children() -> set[int]:
    """This process's children but Python's own resource tracker (one per interpreter, it ends
    with it)."""
    return {
        child.pid
        for child in psutil.Process().children(recursive=True)
        if "resource_tracker" not in " ".join(child.cmdline())
    }


def test_a_two_worker_local_cluster_gives_the_summary_of_one_process_and_leaves_nothing_running(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    before = _children()
    args = ("--budget", "4", "--campaign-s", "3", "--seed", "9", "--out", str(tmp_path))
    here = _verify(capsys, *args, "--jobs", "1")
    status, summary = _verify(capsys, *args, "--cluster", "local", "--jobs", "2")
    assert (status, _what(summary)) == (here[0], _what(here[1]))
    assert (summary["jobs"], summary["cluster"]) == (2, "local")
    assert _children() <= before  # the workers and their nannies are gone


def test_drawn_robot_files_go_out_on_the_cluster_and_give_the_result_of_one_process(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    args = ("--draw-robots", "2", "--budget", "4", "--campaign-s", "2", "--out", str(tmp_path))
    here = _verify(capsys, *args, "--jobs", "1")
    status, result = _verify(capsys, *args, "--cluster", "local", "--jobs", "2")
    assert (status, _what(result)) == (here[0], _what(here[1]))
    assert result["campaigns"] == 4
    assert result["cluster"] == "local"


def test_a_cluster_runs_for_a_duration_too(capsys: pytest.CaptureFixture[str]) -> None:
    status, summary = _verify(
        capsys, "--duration", "1", "--campaign-s", "1", "--cluster", "local", "--jobs", "1"
    )
    assert status == 0
    assert isinstance(summary["campaigns"], int)
    assert summary["campaigns"] >= 1


def test_ctrl_c_shuts_the_local_cluster_down_and_leaves_nothing_running(tmp_path: Path) -> None:
    def a_worker_is_up(children: list[psutil.Process]) -> bool:
        return any(_ignores_sigint(p) and "spawn_main" in _title(p) for p in children)

    _ctrl_c_ends_it(["--cluster", "local", "--jobs", "1", "--out", str(tmp_path)], a_worker_is_up)


def _ctrl_c_ends_it(arguments: list[str], ready: Callable[[list[psutil.Process]], bool]) -> None:
    """`bywire verify` with `arguments`, interrupted as the terminal does (SIGINT to every process
    of its group) once `ready` holds of its descendants: exit 130, nothing on stderr (no worker's
    traceback either), and its whole group gone."""
    command = [sys.executable, "-m", "bywire.cli.main", "verify", "--budget", "400"]
    command += ["--campaign-s", "5", *arguments]
    process = subprocess.Popen(
        command,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=_as_a_shell_starts_it,  # noqa: PLW1509 -- two signal calls, no lock taken
    )
    try:
        verify_process = psutil.Process(process.pid)
        assert _until(lambda: ready(verify_process.children(recursive=True)))
        os.killpg(process.pid, signal.SIGINT)
        _, error = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 130
    assert error.decode() == ""
    assert _until(lambda: not _group_alive(process.pid))


def _as_a_shell_starts_it() -> None:
    """In the child before `exec`: SIGINT at its default and unblocked, as a terminal's shell
    starts a command. A non-interactive shell starts a background job (`pytest ... &`, as a
    script or an agent runs the suite) with SIGINT ignored; the disposition survives `exec`,
    Python then installs no KeyboardInterrupt handler, and `bywire verify` started from that
    pytest was deaf to Ctrl-C: it ran its 400 campaigns and exited 0 (two full runs,
    2026-12-07, both started with `&`; `(python3 -c 'import signal;
    print(signal.getsignal(signal.SIGINT))' &)` prints 1, SIG_IGN)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _until(condition: Callable[[], bool], tries: int = 600) -> bool:
    """Polls `condition` (every 0.1 s, at most a minute by default): whether it came true."""
    for _ in range(tries):
        if condition():
            return True
        time.sleep(0.1)
    return False


def _title(process: psutil.Process) -> str:
    try:
        return " ".join(process.cmdline())
    except psutil.Error:
        return ""


def _group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
    except ProcessLookupError:
        return False
    return True


def test_without_dask_the_cluster_says_in_one_line_how_to_install_it(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "dask", None)  # import dask raises ImportError
    monkeypatch.setitem(sys.modules, "distributed", None)
    assert main(["verify", "--budget", "1", "--cluster", "local"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert "pip install 'bywire[cluster]'" in error


@pytest.mark.parametrize("address", ["somewhere", "tcp://", ""])
def test_a_cluster_address_that_names_no_scheduler_is_refused(
    address: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as caught:
        main(["verify", "--cluster", address])
    assert caught.value.code == 2
    assert "tcp://127.0.0.1:8786" in capsys.readouterr().err


@pytest.mark.parametrize("threads", [1, 2])
def test_a_cluster_the_user_runs_is_used_with_one_thread_a_worker_and_refused_with_more(
    threads: int, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    args = ("--budget", "2", "--campaign-s", "2", "--seed", "3", "--out", str(tmp_path))
    with their_cluster(threads) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        if threads == 1:
            here = _verify(capsys, *args, "--jobs", "1")
            status, summary = _verify(capsys, *args, "--cluster", address)
            assert (status, _what(summary)) == (here[0], _what(here[1]))
            assert (summary["jobs"], summary["cluster"]) == (1, address)
            return
        assert main(["verify", *args, "--cluster", address]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert "runs 2 threads" in error
    assert "--nthreads 1" in error


def test_a_cluster_that_loses_its_workers_mid_run_stops_it_summarising_what_ran(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Every worker of the user's cluster stops mid-run: verify waited for ever; it now stops
    after --workers-wait-s, summarises the campaigns that came back, says why in one line with
    what to do, and exits 1 (not clean: the budget was not run)."""
    args = ["--budget", "40", "--campaign-s", "2", "--seed", "5", "--out", str(tmp_path)]
    ended: list[int] = []
    with their_cluster() as theirs:
        first_result = FirstResult()
        theirs.scheduler.add_plugin(first_result)
        address = theirs.scheduler_address
        run = ["verify", "--json", *args, "--cluster", address, "--workers-wait-s", "0.5"]
        verifying = threading.Thread(target=lambda: ended.append(main(run)), daemon=True)
        verifying.start()
        assert first_result.held.wait(60)
        theirs.scale(0)  # every worker leaves
        verifying.join(60)
        assert not verifying.is_alive(), "verify still waits on a cluster without a worker"
    summary = json.loads(capsys.readouterr().out)
    assert ended == [1]
    assert f"the cluster at {address} has had no worker for 0.5 s" in summary["stopped"]
    assert summary["campaigns"] < 40  # none, if the first result went with the worker
    verify._print_summary(Console(), summary, default_sim_config())
    shown = capsys.readouterr().out
    assert f"stopped after {summary['campaigns']} campaigns: the cluster at" in shown
    assert "result: incomplete, clean so far" in shown


def test_a_cluster_without_a_worker_at_the_start_is_refused_after_workers_wait_s(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    with their_cluster() as theirs:
        theirs.scale(0)
        for _ in range(600):  # until the scheduler has seen its worker go
            if not theirs.scheduler.workers:
                break
            time.sleep(0.05)
        assert not theirs.scheduler.workers
        run = ["verify", "--budget", "1", "--out", str(tmp_path), "--workers-wait-s", "0.5"]
        status = main([*run, "--cluster", theirs.scheduler_address])
    error = capsys.readouterr().err
    assert status == 2
    assert error.count("\n") == 1
    assert "has no worker after 0.5 s" in error
    assert "--workers-wait-s" in error


def test_a_campaign_that_crashes_its_worker_twice_is_reported_with_its_seed_and_index(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    args = ("--budget", "3", "--campaign-s", "1", "--seed", "4", "--out", str(tmp_path))
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 1}),
        their_cluster() as cluster,
        Client(cluster) as client,  # type: ignore[no-untyped-call]
    ):
        client.register_plugin(CrashAt(1), name="crash-always")  # the test's own hook
        status, summary = _verify(capsys, *args, "--cluster", cluster.scheduler_address)
        assert main(["verify", *args, "--cluster", cluster.scheduler_address]) == 1
    assert status == 1
    assert summary["crashes"] == [{"seed": 4, "index": 1, "worker_deaths": 2}]
    assert summary["campaigns"] == 2  # the others ran
    assert "campaign 1 of seed 4 killed its worker twice" in capsys.readouterr().out


def test_command_frames_the_simulated_computer_never_sent_are_a_run_problem_not_a_verdict(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A campaign whose doubled movement frames cost five lights frames their mailbox (the
    computer sent fewer commands than the campaign drew): the summary names the frames and the
    campaign, in JSON and in text, and the verdict is the oracle's alone (clean: exit 0)."""
    robot = parse_config("", "robot.toml")
    # `arm` takes a ControlMode: the string "rc" armed CAN in the pure build (it `is not RC`)
    # and is refused by the compiled one
    steps = [Step(0.5, "doubles", 5), Step(1.0, "arm", ControlMode.RC)]
    outcome = run_campaign(robot, steps, index=7)
    assert outcome.hlc_refused == {"LightsCommand": 5}
    assert outcome.findings == []

    def one_campaign(*_args: object, **_kwargs: object) -> Iterator[Outcome]:
        yield outcome

    monkeypatch.setattr(verify, "campaign_outcomes", one_campaign)
    status, summary = _verify(capsys, "--budget", "1", "--jobs", "1", "--out", str(tmp_path))
    assert status == 0
    assert summary["hlc_refused"] == {"frames": {"LightsCommand": 5}, "campaigns": [7]}
    assert main(["verify", "--budget", "1", "--jobs", "1", "--out", str(tmp_path)]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "run problem: the simulated computer never sent 5 command frames" in text
    assert "(LightsCommand 5) in 1 campaigns" in text
    assert "result: clean" in text


def test_a_run_whose_computer_sent_everything_names_no_run_problem(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    status, summary = _verify(
        capsys, "--budget", "1", "--campaign-s", "3", "--jobs", "1", "--out", str(tmp_path)
    )
    assert status == 0
    assert summary["hlc_refused"] == {"frames": {}, "campaigns": []}


# --- --jobs N: a campaign that kills or hangs its worker is a finding, the run goes on ----------


def _kill_or_hang_at(monkeypatch: pytest.MonkeyPatch, index: int, hang: bool) -> None:
    """Campaign `index` kills its worker (or hangs in it) every time: patched before the
    workers fork, so only they see it."""
    real = engine.run_indexed

    def patched(robot: RobotConfig, job: CampaignJob, at: int) -> Outcome:
        if at == index:
            if hang:
                threading.Event().wait()
            os._exit(9)
        return real(robot, job, at)

    monkeypatch.setattr(engine, "run_indexed", patched)


def test_with_jobs_a_campaign_that_kills_its_worker_twice_is_reported_and_the_rest_run(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _kill_or_hang_at(monkeypatch, 1, hang=False)
    args = ("--budget", "3", "--campaign-s", "1", "--seed", "4", "--out", str(tmp_path))
    status, summary = _verify(capsys, *args, "--jobs", "2")
    assert status == 1
    assert summary["crashes"] == [{"seed": 4, "index": 1, "worker_deaths": 2}]
    assert summary["hangs"] == []
    assert summary["campaigns"] == 2  # the others ran
    assert main(["verify", *args, "--jobs", "2"]) == 1
    assert "campaign 1 of seed 4 killed its worker twice" in capsys.readouterr().out


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_campaign_past_its_real_time_limit_is_reported_as_a_hang_and_the_rest_run(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path, jobs: str
) -> None:
    _kill_or_hang_at(monkeypatch, 2, hang=True)
    args = ("--budget", "4", "--campaign-s", "1", "--seed", "4", "--out", str(tmp_path))
    status, summary = _verify(capsys, *args, "--hang-s", "2", "--jobs", jobs)
    assert status == 1
    assert summary["hangs"] == [{"seed": 4, "index": 2, "limit_s": 2.0}]
    assert summary["crashes"] == []
    assert summary["campaigns"] == 3


def test_a_hang_is_named_in_the_summary_and_the_limit_in_help(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _kill_or_hang_at(monkeypatch, 0, hang=True)
    args = ["--budget", "1", "--campaign-s", "1", "--seed", "3", "--out", str(tmp_path)]
    assert main(["verify", *args, "--hang-s", "1", "--jobs", "1"]) == 1
    assert "campaign 0 of seed 3 still ran after 1 s of real time" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["verify", "--help"])
    assert "--hang-s S" in capsys.readouterr().out


def test_ctrl_c_ends_the_jobs_workers_and_leaves_nothing_running(tmp_path: Path) -> None:
    def both_workers_are_up(children: list[psutil.Process]) -> bool:
        return sum(map(_ignores_sigint, children)) == 2

    _ctrl_c_ends_it(["--jobs", "2", "--out", str(tmp_path)], both_workers_are_up)


def _ignores_sigint(process: psutil.Process) -> bool:
    """Up and ignoring SIGINT, as a worker sets itself (its `SigIgn` mask in /proc)."""
    try:
        status = Path(f"/proc/{process.pid}/status").read_text()
    except OSError:
        return False
    ignored = int(next(line for line in status.splitlines() if line.startswith("SigIgn:"))[7:], 16)
    return bool(ignored & (1 << (signal.SIGINT - 1)))


def test_a_verify_killed_outright_leaves_no_worker_behind(tmp_path: Path) -> None:
    """SIGKILL gives the parent no way out: each worker reads the end of its pipe and returns
    (after its campaign at most), as no other process holds the parent's ends."""
    command = [sys.executable, "-m", "bywire.cli.main", "verify", "--budget", "400"]
    command += ["--campaign-s", "2", "--jobs", "2", "--out", str(tmp_path)]
    process = subprocess.Popen(
        command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        verify_process = psutil.Process(process.pid)
        assert _until(
            lambda: sum(map(_ignores_sigint, verify_process.children(recursive=True))) == 2
        )
        process.kill()
        process.wait()
        assert _until(lambda: not _group_alive(process.pid))
    finally:
        if _group_alive(process.pid):
            os.killpg(process.pid, signal.SIGKILL)


def test_the_hang_limit_grows_with_a_long_campaign_and_an_asked_one_is_kept() -> None:
    """A campaign of 5,000 simulated seconds runs about 2 minutes at 40x real time: the fixed
    120 s default reported it as a hang. Slower than real time, it is stuck."""
    assert verify.hang_limit_s(None, 20.0) == engine.HANG_S
    assert verify.hang_limit_s(None, 5000.0) == 5000.0
    assert verify.hang_limit_s(3.0, 5000.0) == 3.0
