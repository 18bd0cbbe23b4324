"""`bywire bench --builds`: the option, the refusals, the interleaving, and a real side-by-side run.

The main suite has one build of bywire; the run here measures it against a copy of its sources
on PYTHONPATH (a second install of the same code, an A/A run). CI's compiled tier runs the same
test from the compiled venv, where A is the compiled build and B the pure sources. No test
asserts how fast anything is: which build each figure is, the order of the runs and the
arithmetic of the figures are what is checked.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bywire.bench import builds
from bywire.bench.builds import Build, BuildsSettings, RoundFigures
from bywire.cli.main import main
from bywire.errors import ConfigError

SOURCES = Path(__file__).resolve().parents[2] / "src"


def _run(build: int, round_: int, *, course_wall_s: float, verify_cpu_s: float) -> RoundFigures:
    return RoundFigures(
        build=build,
        round=round_,
        course_simulated_s=40.0,
        course_wall_s=course_wall_s,
        course_cpu_s=course_wall_s / 2,
        campaigns=10,
        verify_wall_s=2 * verify_cpu_s,
        verify_cpu_s=verify_cpu_s,
        load_1m=1.0,
    )


def _wrapper(path: Path, python: str, pythonpath: Path | None) -> str:
    """A Python that is `python`, with `pythonpath` first on its path."""
    env = f"PYTHONPATH={pythonpath} " if pythonpath is not None else ""
    path.write_text(f'#!/bin/sh\n{env}exec {python} "$@"\n')
    path.chmod(0o755)
    return str(path)


@pytest.fixture
def copied_sources(tmp_path: Path) -> Path:
    """A second install of the same code: the checkout's pure sources, copied."""
    target = tmp_path / "copy" / "src"
    shutil.copytree(
        SOURCES,
        target,
        ignore=shutil.ignore_patterns("__pycache__", "*.so", "_compiled.json", "*.egg-info"),
    )
    return target


# --- the option --------------------------------------------------------------------------------


def test_builds_are_two_or_more_pythons_separated_by_commas() -> None:
    assert builds.parse_builds(".venv/bin/python, .venv-c/bin/python") == [
        ".venv/bin/python",
        ".venv-c/bin/python",
    ]
    assert len(builds.parse_builds(",".join(["p"] * builds.MAX_BUILDS))) == builds.MAX_BUILDS


@pytest.mark.parametrize(
    "text", ["", ".venv/bin/python", ".venv/bin/python,", ",".join(["p"] * (builds.MAX_BUILDS + 1))]
)
def test_builds_refuses_fewer_than_two_an_empty_one_or_too_many(text: str) -> None:
    with pytest.raises(ConfigError, match="--builds"):
        builds.parse_builds(text)


@pytest.mark.parametrize(
    ("rounds", "budget", "key"),
    [
        (0, 1, "--rounds"),
        (builds.MAX_ROUNDS + 1, 1, "--rounds"),
        (1, 0, "--budget"),
        (1, builds.MAX_BUDGET + 1, "--budget"),
    ],
)
def test_rounds_and_budget_out_of_range_are_refused_naming_them(
    rounds: int, budget: int, key: str
) -> None:
    with pytest.raises(ConfigError, match=f"{key} .*use 1 to"):
        BuildsSettings(rounds, budget, None, None).checked()


def test_the_edges_of_rounds_and_budget_are_taken() -> None:
    for rounds, budget in ((1, 1), (builds.MAX_ROUNDS, builds.MAX_BUDGET)):
        settings = BuildsSettings(rounds, budget, None, None)
        assert settings.checked() is settings


@pytest.mark.parametrize(
    "argv",
    [
        ["bench", "--rounds", "2"],
        ["bench", "--budget", "2"],
        ["bench", "--builds", "a,b", "--look"],
        ["bench", "--builds", "a,b", "--probe"],
        ["bench", "--builds", "a,b", "--realtime"],
        ["bench", "--builds", "a"],
    ],
)
def test_options_that_do_not_go_together_are_refused_with_one_line(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("bywire bench: error: --")
    assert err.count("\n") == 1


# --- the order and the figures -----------------------------------------------------------------


def test_the_builds_run_interleaved_every_round_in_the_order_given() -> None:
    assert builds.schedule(2, 3) == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
    assert builds.schedule(3, 1) == [(0, 0), (0, 1), (0, 2)]


def test_a_builds_figures_add_up_its_own_rounds_only() -> None:
    runs = [
        _run(0, 0, course_wall_s=2.0, verify_cpu_s=6.0),
        _run(1, 0, course_wall_s=1.0, verify_cpu_s=3.0),
        _run(0, 1, course_wall_s=2.0, verify_cpu_s=4.0),
        _run(1, 1, course_wall_s=0.5, verify_cpu_s=2.0),
    ]
    pure, compiled = builds.totals(runs, 0), builds.totals(runs, 1)
    assert pure.course_x_realtime == pytest.approx(80.0 / 4.0)
    assert pure.course_x_cpu == pytest.approx(80.0 / 2.0)
    assert pure.campaigns_per_cpu_minute == pytest.approx(20 * 60 / 10.0)  # CPU, not wall
    assert pure.campaigns_per_wall_minute == pytest.approx(20 * 60 / 20.0)
    assert compiled.course_x_realtime == pytest.approx(80.0 / 1.5)
    assert compiled.campaigns_per_cpu_minute == pytest.approx(20 * 60 / 5.0)
    assert builds.round_ratios(runs, 1, "campaigns_per_cpu_minute") == pytest.approx([2.0, 2.0])
    assert builds.round_ratios(runs, 1, "course_x_realtime") == pytest.approx([2.0, 4.0])


# --- which Pythons ------------------------------------------------------------------------------


def test_a_python_without_bywire_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bare = tmp_path / "bare"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(bare)], check=True)
    python = str(bare / "bin" / "python")
    assert main(["bench", "--builds", f"{sys.executable},{python}", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"{python} has no bywire installed" in err
    assert "run 1/" not in err  # refused before anything ran


def test_a_python_that_cannot_run_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = str(tmp_path / "no-such-python")
    assert main(["bench", "--builds", f"{sys.executable},{missing}", "--quick"]) == 2
    assert f"cannot run {missing}" in capsys.readouterr().err


def test_the_same_build_twice_is_refused_even_through_another_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    same = _wrapper(tmp_path / "python", sys.executable, None)
    for pythons in (f"{sys.executable},{sys.executable}", f"{sys.executable},{same}"):
        assert main(["bench", "--builds", pythons, "--quick"]) == 2
        err = capsys.readouterr().err
        assert "run the same bywire" in err
        assert "run 1/" not in err


def test_a_quick_run_measures_each_build_in_its_own_python_interleaved(
    tmp_path: Path, copied_sources: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = _wrapper(tmp_path / "python", sys.executable, copied_sources)
    argv = ["bench", "--builds", f"{sys.executable},{other}", "--quick", "--budget", "1", "--json"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    document = json.loads(captured.out)
    a, b = document["builds"]
    # each figure says which build it is: the Python given, and the package that Python ran
    assert (a["label"], a["python"]) == ("A", sys.executable)
    assert (b["label"], b["python"]) == ("B", other)
    assert b["package"] == str((copied_sources / "bywire").resolve())
    assert a["package"] != b["package"]
    assert b["build"] == "pure"  # the copy has no compiled modules
    # A B A B: the order they ran in, with the progress line of each before it
    runs = document["runs"]
    assert [(run["round"], run["build"]) for run in runs] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert captured.err.count("bywire bench: run ") == 4
    assert "run 2/4: B, pure" in captured.err
    for run in runs:
        assert run["campaigns"] == 1
        assert run["course_simulated_s"] == pytest.approx(10.0, abs=0.05)
        assert run["verify_cpu_s"] > 0
        assert run["course_cpu_s"] > 0
    # the ratio is B's figure over A's, each the sum of its own rounds
    for name, _title in builds.FIGURES:
        assert b["ratio_to_A"][name] == pytest.approx(b["figures"][name] / a["figures"][name])
    cpu = sum(run["verify_cpu_s"] for run in runs if run["build"] == 1)
    assert b["figures"]["campaigns_per_cpu_minute"] == pytest.approx(2 * 60 / cpu)


def test_the_table_names_every_build_and_gives_the_ratio_with_its_spread() -> None:
    runs = (
        _run(0, 0, course_wall_s=2.0, verify_cpu_s=6.0),
        _run(1, 0, course_wall_s=1.0, verify_cpu_s=3.0),
        _run(0, 1, course_wall_s=2.0, verify_cpu_s=4.0),
        _run(1, 1, course_wall_s=0.5, verify_cpu_s=2.0),
    )
    result = builds.BuildsResult(
        builds=(
            Build(".venv/bin/python", "pure", "/a/bywire", "0.1.0", "3.11.7"),
            Build(".venv-c/bin/python", "compiled (mypyc 2.4.1, -O3)", "/b/bywire", "0.1.0", "3"),
        ),
        runs=runs,
        course_s=None,
        budget=10,
        machine={},
    )
    table = builds.render(result)
    assert "A: pure build" in table
    assert ".venv/bin/python (/a/bywire)" in table
    assert "B: compiled (mypyc 2.4.1, -O3) build" in table
    assert "2 round(s) of the whole test course and 10 verify campaign(s)" in table
    cpu_row = next(line for line in table.splitlines() if "per CPU-minute" in line)
    assert cpu_row.split()[-3:] == ["240.0", "2.00", "(2.00-2.00)"]
    course_row = next(line for line in table.splitlines() if "x real time" in line)
    assert course_row.split()[-2:] == ["2.67", "(2.00-4.00)"]
