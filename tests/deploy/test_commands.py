"""What the deploy tier types is read from the docs: every line of docs/DEPLOY.md's install block
and the README's two commands, verbatim and in order; each line the tier expects to fail or stops
by Ctrl-C is named by a pattern matching exactly one line."""

from __future__ import annotations

import re

import pytest

from tests.deploy import commands

STEPS = commands.plan()


def test_the_plan_types_the_install_block_verbatim_and_in_order() -> None:
    typed = [step.text for step in STEPS if step.source == "docs/DEPLOY.md"]
    assert typed == commands.install_block()
    assert len(typed) >= 15
    assert any(re.search(commands.RUN_CHECK, line) for line in typed)


def test_the_plan_types_the_readme_commands_as_the_developer() -> None:
    (run_first, run), (test_first, test) = commands.readme_commands()
    readme = [(step.text, step.user) for step in STEPS if step.source == "README.md"]
    assert readme == [
        (run_first, "root"),
        (run, commands.DEVELOPER),
        (test, commands.DEVELOPER),
    ]
    assert run.endswith("bywire sim")
    assert test.endswith("pytest")
    assert run_first.startswith("sudo apt-get install")
    assert test_first == ""  # the tests need nothing the run command did not install


@pytest.mark.parametrize("pattern", [*commands.EXPECTED_FAILURES, *commands.INTERRUPTED])
def test_each_expected_failure_names_exactly_one_line(pattern: str) -> None:
    assert len([line for line in commands.install_block() if re.search(pattern, line)]) == 1


def test_packages_are_installed_online_and_the_robot_side_runs_offline() -> None:
    phases = {step.text: step.phase for step in STEPS}
    for text, phase in phases.items():
        if any(marker in text for marker in commands.ONLINE_MARKERS):
            assert phase == "online", text
    assert all(phase == "offline" for text, phase in phases.items() if "robot.toml --check" in text)


def test_a_changed_line_in_the_markdown_is_what_gets_typed() -> None:
    doc = commands.DEPLOY.read_text(encoding="utf-8")
    changed = doc.replace("sudo systemd-sysusers", "sudo systemd-sysuser", 1)
    assert "sudo systemd-sysuser\n" in "\n".join(commands.install_block(changed)) + "\n"
    with pytest.raises(ValueError, match="no '## Install' section"):  # refused, not empty
        commands.install_block(doc.replace("\n## Install\n", "\n## Setup\n"))
