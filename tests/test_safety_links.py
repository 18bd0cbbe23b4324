"""The safety truth kept in step (issue 42, item 3): every stop cause, every command message and
every fault of the scenario language has its row in `docs/SAFETY.md`'s hazard table, and a fault
that `bywire verify` can inject.

A hazard row names what it covers in one parenthesis after its hazard, which this test reads:
`(links: `Cause.RC_LOST`, `MovementCommand`, `fault = "rc_link_lost"`)` — a latched cause of
`control/supervisor.py`, a command message (a row of `bywire.command_table`), a fault as a
scenario writes it (`sim/faults.py`). A new cause, command or fault fails here until a row names
it; a row that names one that no longer exists fails too.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

import pytest

from bywire.command_table import COMMANDS as COMMAND_ROWS
from bywire.config import default_sim_config
from bywire.control.supervisor import CAN_BOUND, Cause
from bywire.model import ControlMode
from bywire.sim.faults import BY_NAME as FAULTS
from bywire.sim.runner import SimRun
from bywire.sim.verify.actions import ACTIONS, compile_steps
from bywire.sim.verify.actions import BY_NAME as VERIFY_ACTIONS
from bywire.sim.verify.campaign import Step

SAFETY = Path(__file__).resolve().parent.parent / "docs" / "SAFETY.md"
COMMANDS = tuple(row.name for row in COMMAND_ROWS)

ROW = re.compile(r"^\| (\d+) \| .*$", re.M)
LINKS = re.compile(r"\(links: ([^)]*)\)")
CAUSE = re.compile(r"`Cause\.(\w+)`")
FAULT = re.compile(r'`fault = "(\w+)"`')
COMMAND = re.compile(r"`(\w+Command)`")

PROVOKED_OTHERWISE: Mapping[Cause, str | None] = {
    # every run begins with it: each campaign's first arming clears it
    Cause.POWER_UP: None,
    # asked for by the computer, not a fault: verify's `remote_stop` action (its hazard rows 18
    # and 35 name no fault of it)
    Cause.REMOTE_STOP: "remote_stop",
}
"""Causes that no scenario fault brings on, and the verify action that does (None: none)."""

NOT_DRAWN: Mapping[str, str] = {
    # the watchdog's limit is wall-clock time: verify plays virtual time; its cause, WATCHDOG,
    # is brought on by `dac_stall` (a write that hangs past the limit)
    "loop_stall": "needs realtime",
    # verify draws `can_forgery` alone; the skipping forgery (row 48) is a scenario and test
    # only. Drawing it would change every campaign drawn after it (bench/differential.py)
    "can_skip_forgery": "not in verify's vocabulary",
}
"""Faults of the scenario language that `bywire verify` never injects, and why."""


def hazard_rows(text: str) -> dict[int, str]:
    """The hazard table's rows by number (the rows of the section `## Hazard table`)."""
    table = text[text.index("\n## Hazard table") :]
    table = table[: table.find("\n## ", 1)]
    return {int(match.group(1)): match.group(0) for match in ROW.finditer(table)}


def links(text: str, pattern: re.Pattern[str]) -> dict[str, set[int]]:
    """What each row's links name with `pattern`: name -> the rows naming it."""
    named: dict[str, set[int]] = {}
    for number, row in hazard_rows(text).items():
        for said in LINKS.findall(row):
            for name in pattern.findall(said):
                named.setdefault(name, set()).add(number)
    return named


def _verify_steps() -> dict[str, list[Step]]:
    """Every fault that some step of `bywire verify`'s vocabulary compiles to, with those steps
    (a range of values: its ends)."""
    robot = default_sim_config()
    steps: dict[str, list[Step]] = {}
    for action in ACTIONS:
        values = list(action.values)
        drawn = (values[0], values[-1]) if isinstance(action.values, range) else values
        for value in drawn:
            step = Step(0.0, action.name, value)
            for event in compile_steps([step], robot).events:
                if event.kind == "fault" and step not in steps.get(str(event.values["fault"]), []):
                    steps.setdefault(str(event.values["fault"]), []).append(step)
    return steps


TEXT = SAFETY.read_text(encoding="utf-8")
VERIFY_STEPS = _verify_steps()
VERIFY_INJECTS = frozenset(VERIFY_STEPS)


def _faults_of(rows: set[int]) -> set[str]:
    by_fault = links(TEXT, FAULT)
    return {fault for fault, named_in in by_fault.items() if named_in & rows}


def test_every_stop_cause_has_its_hazard_row() -> None:
    named = links(TEXT, CAUSE)
    assert [cause.name for cause in Cause if cause.name not in named] == []


def test_every_command_message_has_its_hazard_row() -> None:
    named = links(TEXT, COMMAND)
    assert [command for command in COMMANDS if command not in named] == []


def test_every_fault_has_its_hazard_row() -> None:
    named = links(TEXT, FAULT)
    assert [fault for fault in FAULTS if fault not in named] == []


def test_every_link_names_a_cause_a_command_or_a_fault_that_exists() -> None:
    assert set(links(TEXT, CAUSE)) - set(Cause.__members__) == set()
    assert set(links(TEXT, COMMAND)) - set(COMMANDS) == set()
    assert set(links(TEXT, FAULT)) - set(FAULTS) == set()


@pytest.mark.parametrize("cause", list(Cause), ids=lambda cause: cause.name)
def test_every_stop_cause_is_brought_on_by_something_verify_injects(cause: Cause) -> None:
    """Through its rows: a fault they name that verify's campaigns inject, or the action that
    asks for it."""
    if cause in PROVOKED_OTHERWISE:
        action = PROVOKED_OTHERWISE[cause]
        assert action is None or action in VERIFY_ACTIONS
        return
    injected = _faults_of(links(TEXT, CAUSE).get(cause.name, set())) & VERIFY_INJECTS
    assert injected, f"no row of Cause.{cause.name} names a fault that verify injects"


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_message_has_a_fault_verify_injects(command: str) -> None:
    injected = _faults_of(links(TEXT, COMMAND).get(command, set())) & VERIFY_INJECTS
    assert injected, f"no row of {command} names a fault that verify injects"


def test_every_fault_is_one_verify_injects_or_says_why_not() -> None:
    assert [fault for fault in FAULTS if fault not in VERIFY_INJECTS | set(NOT_DRAWN)] == []
    assert set(NOT_DRAWN) & VERIFY_INJECTS == set()  # an excuse no longer needed goes
    assert set(NOT_DRAWN) <= set(FAULTS)


def test_the_links_of_a_row_are_read_and_a_missing_one_is_found() -> None:
    """The reader's teeth: a cause whose only link is dropped is missing, and the row of one
    named in two rows still counts."""
    assert links(TEXT, CAUSE)["TIMING"] == {36}
    assert links(TEXT, CAUSE)["CAN_LOST"] == {2, 8}
    assert links(TEXT, FAULT)["rc_link_lost"] == {1}
    without = TEXT.replace("`Cause.TIMING`, ", "")
    assert "TIMING" not in links(without, CAUSE)
    assert "CAN_LOST" in links(without, CAUSE)
    outside = TEXT.replace("## Hazard table", "## Hazard table\n\n## Elsewhere")
    assert links(outside, CAUSE) == {}  # only the hazard table's rows count


def _latched_after(step: Step, mode: ControlMode) -> set[Cause]:
    """The causes the controller latches once `step` is done to a robot armed at `mode` and
    driving, then steering and braking (what a broken servo or brake needs to show)."""
    robot = default_sim_config()
    can = mode is ControlMode.CAN
    steps = [
        Step(0.0, "arm", mode),
        Step(0.3, "can_throttle" if can else "rc_throttle", 0.3),
        Step(0.3, step.action, step.value),
        Step(0.05, "can_steer" if can else "rc_steer", 0.5),
        Step(0.05, "can_brake" if can else "rc_throttle", 1.0 if can else -1.0),
        Step(1.5, "rc_lights", False),  # time for the monitors
    ]
    run = SimRun(robot, compile_steps(steps, robot))
    latched: set[Cause] = set()

    def observe(now: float) -> None:
        outputs = run.runtime.outputs
        if outputs is not None and now >= FAULT_AT_S:
            latched.update(outputs.causes)

    run.runtime.on_cycle.append(observe)
    run.run()
    return latched


FAULT_AT_S = 0.6


def _steps_bringing_on(cause: Cause) -> dict[str, list[Step]]:
    """What verify does that should bring `cause` on, by name: the faults its rows name, or the
    action that asks for it."""
    action = PROVOKED_OTHERWISE.get(cause)
    if action is not None:
        return {action: [Step(0.0, action, value) for value in VERIFY_ACTIONS[action].values]}
    faults = sorted(_faults_of(links(TEXT, CAUSE).get(cause.name, set())) & VERIFY_INJECTS)
    return {fault: VERIFY_STEPS[fault] for fault in faults}


@pytest.mark.parametrize(
    "cause", [cause for cause in Cause if cause is not Cause.POWER_UP], ids=lambda c: c.name
)
def test_what_a_causes_rows_name_brings_the_cause_on_in_the_controller(cause: Cause) -> None:
    """The links are true: some fault a cause's rows name (or its action), done as verify does
    it to a robot armed and driving (in CAN mode for the CAN-bound causes), latches it."""
    mode = ControlMode.CAN if cause in CAN_BOUND else ControlMode.RC
    tried: dict[str, list[str]] = {}
    for name, steps in _steps_bringing_on(cause).items():
        for step in steps:
            latched = _latched_after(step, mode)
            if cause in latched:
                return
            tried[f"{name} ({step.action} {step.value})"] = sorted(c.name for c in latched)
    pytest.fail(f"nothing the rows of Cause.{cause.name} name latches it: {tried}")
