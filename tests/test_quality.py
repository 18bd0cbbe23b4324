"""Project-wide checks: lint, strict typing, and the README and CI running the same test command."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


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
