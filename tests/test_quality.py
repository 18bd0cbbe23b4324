"""Project-wide checks: lint, strict typing, and the README and CI running the same test command."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.layers import LAYERS, SOURCE, imports, unit_of, upward

ROOT = Path(__file__).resolve().parent.parent

pytest_plugins = ["pytester"]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, check=False
    )


@pytest.mark.parametrize(
    "command",
    [("ruff", "check", "src", "tests"), ("ruff", "format", "--check", "src", "tests")],
    ids=["ruff-check", "ruff-format"],
)
def test_ruff_is_clean(command: tuple[str, ...]) -> None:
    result = _run(*command)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.long
def test_mypy_strict_is_clean() -> None:
    result = _run("mypy", "--strict", "src", "tests")
    assert result.returncode == 0, result.stdout + result.stderr


def _readme_commands() -> list[str]:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```(?:sh|bash|console)?\n(.*?)```", readme, flags=re.DOTALL)
    return [line.strip() for block in blocks[:2] for line in block.splitlines() if line.strip()]


def test_readme_starts_with_two_commands_run_and_test() -> None:
    run_command, test_command = _readme_commands()[:2]
    assert "bywire " in run_command
    assert "pytest" in test_command


def test_pytest_xdist_is_installed_by_the_test_command_and_keeps_the_groups() -> None:
    """`pytest -n auto` works in the README's fresh .venv (pytest-xdist in the test extra), with
    `--dist loadgroup` from pyproject so that an `xdist_group` runs on one worker. The README's
    command itself runs serially: the real-time tests (`bywire run`, the RC tool's simulated
    transmitter, the ROS 2 link process, the Ctrl-C tests) miss their deadlines beside another
    worker on a 2-core machine."""
    test_command = _readme_commands()[1]
    assert test_command.endswith("python -m pytest")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    extra = project["project"]["optional-dependencies"]["test"]
    assert any(re.match(r"pytest-xdist\b", requirement) for requirement in extra)
    assert "--dist loadgroup" in project["tool"]["pytest"]["ini_options"]["addopts"]


@pytest.mark.parametrize("worker", ["gw0", ""], ids=["xdist", "serial"])
def test_under_xdist_the_long_tests_are_collected_first_and_the_rest_keep_their_order(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, worker: str
) -> None:
    monkeypatch.setenv("PYTEST_XDIST_WORKER", worker)
    pytester.makeconftest(
        "from tests.conftest import pytest_collection_modifyitems  # noqa: F401\n"
    )
    pytester.makeini("[pytest]\nmarkers =\n    long: long\n")
    pytester.makepyfile(
        "import pytest\n"
        "def test_a(): pass\n"
        "@pytest.mark.long\n"
        "def test_b(): pass\n"
        "def test_c(): pass\n"
        "@pytest.mark.long\n"
        "@pytest.mark.parametrize('n', [1, 2])\n"
        "def test_d(n): pass\n"
    )
    pytester.syspathinsert(ROOT)
    listed = pytester.runpytest("--collect-only", "-q", "-p", "no:cacheprovider").outlines
    names = [line.split("::")[1] for line in listed if "::" in line]
    if worker:
        assert names == ["test_b", "test_d[1]", "test_d[2]", "test_a", "test_c"]
    else:  # the README's serial command: the files' own order
        assert names == ["test_a", "test_b", "test_c", "test_d[1]", "test_d[2]"]


def test_ci_runs_the_readme_test_command_verbatim() -> None:
    test_command = _readme_commands()[1]
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test_command in ci_lines


def test_ci_runs_the_ros_tier_after_the_readme_test_command_and_it_cannot_skip() -> None:
    """The ROS 2 tier runs after the main suite, in its own venv, where a missing rclpy fails
    instead of skipping; the main suite's skip line names the script that enables it."""
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    tier_call = "bash .ci/ros-tier"
    assert tier_call in ci_lines
    assert ci_lines.index(tier_call) > ci_lines.index(_readme_commands()[1])
    tier = (ROOT / ".ci" / "ros-tier").read_text(encoding="utf-8")
    assert "set -euo pipefail" in tier
    run_line = next(line for line in tier.splitlines() if "pytest" in line)
    assert run_line.startswith("BYWIRE_ROS_TIER=1 .venv-ros/bin/python -m pytest")
    module = run_line.split()[-1]
    source = (ROOT / module).read_text(encoding="utf-8")
    assert 'os.environ.get("BYWIRE_ROS_TIER") == "1"' in source
    assert "run `.ci/ros-tier`" in source


def test_ci_runs_the_kernel_tier_as_the_readme_says_last() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    tier = readme[readme.index("## The kernel tier") : readme.index("## The deploy tier")]
    blocks = re.findall(r"```sh\n(.*?)```", tier, flags=re.DOTALL)
    install, run = (line.split("#")[0].strip() for line in blocks[0].splitlines()[:2])
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ci_lines = [line.strip() for line in ci.splitlines()]
    assert run == "sudo tests/kernel/run"  # CI runs as root: without the sudo
    assert "Not in CI" not in readme
    order = [
        ci_lines.index(line)
        for line in ("bash .ci/ros-tier", "tests/deploy/run", "tests/kernel/run")
    ]
    assert order == sorted(order)
    assert ci_lines[-1] == "tests/kernel/run"  # last and alone: its guest keeps real time
    readme_packages = install.split()[3:]  # sudo apt-get install PACKAGES…
    ci_blocks = re.findall(r"apt-get install(.*?)>/dev/null", ci, flags=re.DOTALL)
    ci_packages = next(block for block in ci_blocks if "linux-source-6.1" in block).split()
    script = (ROOT / "tests" / "kernel" / "run").read_text(encoding="utf-8")
    listed = re.search(r"PACKAGES = \((.*?)\)", script, flags=re.DOTALL)
    assert listed is not None
    run_packages = "".join(re.findall(r'"([^"]*)"', listed[1])).split()
    assert set(readme_packages) == {word for word in ci_packages if word[0] not in "-\\"}
    assert set(readme_packages) == set(run_packages)


@pytest.mark.parametrize(("ci", "status"), [("", 0), ("true", 1)], ids=["user", "ci"])
def test_the_kernel_tier_without_its_packages_skips_with_one_line_but_fails_under_ci(
    tmp_path: Path, ci: str, status: int
) -> None:
    """A PATH with none of the tools the tier builds its kernel and makes its devices with."""
    said = _said_once(
        [sys.executable, str(ROOT / "tests" / "kernel" / "run")], tmp_path, ci, status
    )
    # linux-source-6.1 is a package, not a tool: named too on a machine that lacks it
    assert re.search(r"missing: (linux-source-6\.1 )?build-essential bc flex bison", said[0])
    assert "apt-get install linux-source-6.1" in said[0]
    assert "README, 'The kernel tier'" in said[0]


def test_ci_runs_the_deploy_tier_as_the_readme_says_after_the_ros_tier() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    tier = readme[readme.index("## The deploy tier") :]
    blocks = re.findall(r"```sh\n(.*?)```", tier, flags=re.DOTALL)
    install, run = (line.split("#")[0].strip() for line in blocks[0].splitlines()[:2])
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ci_lines = [line.strip() for line in ci.splitlines()]
    assert run == "sudo tests/deploy/run"  # CI runs as root: without the sudo
    assert ci_lines.index("bash .ci/ros-tier") < ci_lines.index("tests/deploy/run")
    packages = set(install.split()[3:])  # sudo apt-get install PACKAGES…
    listed = re.search(r"apt-get install[^\n]*\n\s*(debootstrap[^\n]*)>/dev/null", ci)
    assert listed is not None
    assert packages == set(listed[1].split())


@pytest.mark.parametrize(("ci", "status"), [("", 0), ("true", 1)], ids=["user", "ci"])
def test_the_deploy_tier_without_its_tools_skips_with_one_line_but_fails_under_ci(
    tmp_path: Path, ci: str, status: int
) -> None:
    """A PATH with a shell and coreutils but neither debootstrap nor systemd-nspawn."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in ("bash", "id", "dirname", "env"):
        found = shutil.which(tool)
        assert found is not None
        (bin_dir / tool).symlink_to(found)
    said = _said_once(["bash", str(ROOT / "tests" / "deploy" / "run")], bin_dir, ci, status)
    assert "debootstrap systemd-nspawn" in said[0]
    assert "apt-get install debootstrap systemd-container" in said[0]


def _said_once(command: list[str], path: Path, ci: str, status: int) -> list[str]:
    """What a tier's script says run with only `path` on PATH: one line, and `status`."""
    result = subprocess.run(
        command, env={"PATH": str(path), "CI": ci}, capture_output=True, text=True, check=False
    )
    said = (result.stdout + result.stderr).splitlines()
    assert (result.returncode, len(said)) == (status, 1), said
    return said


def test_every_import_runs_down_the_stated_layers() -> None:
    """Issue 35: each unit imports only from the layers below it (`tests/layers.py`)."""
    assert {unit_of(path) for path in SOURCE.rglob("*.py")} == set().union(*LAYERS)
    wrong = upward(imports())
    assert not wrong, "imports that run back up or sideways:\n" + "\n".join(map(str, wrong))


def test_the_layering_check_names_an_import_that_runs_back_up(tmp_path: Path) -> None:
    copy = tmp_path / "bywire"
    shutil.copytree(SOURCE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    tree = copy / "config" / "tree.py"
    tree.write_text(tree.read_text() + "\nfrom bywire.runtime.loop import Runtime\n")
    (wrong,) = upward(imports(copy))
    assert (wrong.importer, wrong.imported) == ("config", "runtime")
    assert str(wrong).endswith("config imports runtime")


def test_ci_builds_the_compiled_tier_beside_the_ros_tier_and_checks_it_after() -> None:
    """Issue 43: .venv-c is built in the background while the ROS and deploy tiers run; a
    failed build prints its log and fails CI, and the compiled checks run before the kernel
    tier, which runs last, alone (its guest keeps real time)."""
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    start = ci_lines.index('setsid bash .ci/compiled-tier build >"$compiled_log" 2>&1 &')
    waited = ci_lines.index('if ! wait "$compiled_build"; then')
    order = [
        start,
        ci_lines.index("bash .ci/ros-tier"),
        ci_lines.index("tests/deploy/run"),
        waited,
        ci_lines.index("bash .ci/compiled-tier check"),
        ci_lines.index("tests/kernel/run"),
    ]
    assert order == sorted(order)
    failed = ci_lines[waited : ci_lines.index("fi", waited)]
    assert 'cat "$compiled_log"' in failed
    assert failed[-1] == "exit 1"
    tier = (ROOT / ".ci" / "compiled-tier").read_text(encoding="utf-8")
    assert "set -euo pipefail" in tier
    assert "BYWIRE_COMPILE=1 .venv-c/bin/pip install '.[test]'" in tier
    assert "BYWIRE_EXPECT_BUILD=compiled .venv-c/bin/python -m pytest" in tier
    assert "PYTHONPATH=. .venv-c/bin/python bench/differential.py check" in tier
    assert 'wait "$differential" || identical=$?' in tier


def _tier_copy(tmp_path: Path) -> tuple[Path, Path]:
    """.ci/compiled-tier in a clone of nothing (its .venv-c is the copy's), and a PATH whose
    python3 fails as a broken build would."""
    (tmp_path / "clone" / ".ci").mkdir(parents=True)
    script = tmp_path / "clone" / ".ci" / "compiled-tier"
    shutil.copy(ROOT / ".ci" / "compiled-tier", script)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in ("bash", "dirname", "rm"):
        found = shutil.which(tool)
        assert found is not None
        (bin_dir / tool).symlink_to(found)
    python3 = bin_dir / "python3"
    python3.write_text("#!/bin/sh\necho 'python3: the build broke' >&2\nexit 3\n")
    python3.chmod(0o755)
    return script, bin_dir


@pytest.mark.parametrize("step", [[], ["check"]], ids=["all", "check"])
def test_the_compiled_tier_elsewhere_than_ci_skips_with_one_line_naming_how_to_run_it(
    tmp_path: Path, step: list[str]
) -> None:
    script, bin_dir = _tier_copy(tmp_path)
    said = _said_once(["bash", str(script), *step], bin_dir, "", 0)
    assert said == [
        "compiled tier skipped (not CI): BYWIRE_COMPILED_TIER=1 .ci/compiled-tier to run it"
    ]
    quiet = subprocess.run(
        ["bash", str(script), "build"],
        env={"PATH": str(bin_dir)},
        capture_output=True,
        text=True,
        check=False,
    )
    assert (quiet.returncode, quiet.stdout, quiet.stderr) == (0, "", "")  # check says it once


@pytest.mark.parametrize("env", [{"CI": "true"}, {"BYWIRE_COMPILED_TIER": "1"}], ids=["ci", "user"])
def test_the_compiled_tier_fails_when_its_build_fails(tmp_path: Path, env: dict[str, str]) -> None:
    script, bin_dir = _tier_copy(tmp_path)
    for step in (["build"], []):
        result = subprocess.run(
            ["bash", str(script), *step],
            env={"PATH": str(bin_dir), **env},
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 3, result.stdout + result.stderr
        assert "the build broke" in result.stderr
        assert "built in" not in result.stdout
