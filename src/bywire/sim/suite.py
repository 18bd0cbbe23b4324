"""`bywire sim --all`: every packaged scenario, or every scenario file in a folder, one after the
other, with a verdict per scenario and a JUnit XML report that CI systems read.

A file that does not load, or a run that cannot start (a key file it needs is missing), is a
failed case of its own (with the one-line reason): one bad file never hides the verdicts of the
others. A scenario that needs sensors the robot does not fit is set aside, not run
(`applicability`).
"""

from __future__ import annotations

import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bywire.config import RobotConfig
from bywire.errors import ConfigError
from bywire.sim.applicability import not_applicable
from bywire.sim.catalog import SUFFIX, packaged_scenario, scenario_names
from bywire.sim.runner import SimRun
from bywire.sim.scenario import Scenario, load_scenario
from bywire.sim.summary import Summary, build_summary

Loader = Callable[[], Scenario]


@dataclass(frozen=True, slots=True)
class Case:
    """One scenario's verdict: its summary, or why it could not run."""

    name: str
    origin: str
    summary: Summary | None
    error: str | None
    wall_s: float
    not_applicable: str | None = None
    """Why the scenario does not apply to the robot (it was not run), or None."""

    @property
    def passed(self) -> bool:
        return self.error is None and self.summary is not None and self.summary.passed

    @property
    def failed(self) -> bool:
        """Neither passed nor set aside as not applicable to the robot."""
        return self.not_applicable is None and not self.passed

    @property
    def reasons(self) -> list[str]:
        """Why it failed: the loader's error, or each failed expectation."""
        if self.error is not None:
            return [self.error]
        return [] if self.summary is None else self.summary.failed


def collect(folder: Path | None) -> list[tuple[str, str, Loader]]:
    """(name, origin, loader) of every packaged scenario (`folder` None) or every *.toml in
    `folder`, sorted by name; ConfigError when the folder holds none."""
    if folder is None:
        return [
            (name, f"bywire/scenarios/{name}{SUFFIX}", _packaged(name)) for name in scenario_names()
        ]
    if not folder.is_dir():
        raise ConfigError(f"--all {folder}: not a folder of scenario files")
    files = sorted(folder.glob(f"*{SUFFIX}"))
    if not files:
        raise ConfigError(f"--all {folder}: no *{SUFFIX} scenario files in it")
    return [(path.stem, str(path), _from_file(path)) for path in files]


def _packaged(name: str) -> Loader:
    return lambda: packaged_scenario(name)


def _from_file(path: Path) -> Loader:
    return lambda: load_scenario(path)


def run_case(robot: RobotConfig, name: str, origin: str, load: Loader) -> Case:
    """Load and play one scenario (in virtual time unless it needs the wall clock)."""
    started = time.perf_counter()
    try:
        scenario = load()
    except ConfigError as error:
        return Case(name, origin, None, str(error), time.perf_counter() - started)
    reason = not_applicable(scenario, robot)
    if reason is not None:
        return Case(name, origin, None, None, time.perf_counter() - started, reason)
    try:
        sim = SimRun(robot, scenario)
    except ConfigError as error:  # what the run needs and cannot have (a key file, say)
        return Case(name, origin, None, str(error), time.perf_counter() - started)
    sim.run()
    wall_s = time.perf_counter() - started
    return Case(name, origin, build_summary(sim, wall_s), None, wall_s)


def junit_xml(cases: list[Case], suite: str = "bywire sim") -> str:
    """A JUnit XML report: one testcase per scenario, a failure per failed expectation, an
    error for a file that did not load, a skip for a scenario that does not apply."""
    failures = sum(1 for case in cases if case.error is None and case.failed)
    errors = sum(1 for case in cases if case.error is not None)
    skipped = sum(1 for case in cases if case.not_applicable is not None)
    root = ET.Element("testsuites")
    node = ET.SubElement(
        root,
        "testsuite",
        name=suite,
        tests=str(len(cases)),
        failures=str(failures),
        errors=str(errors),
        skipped=str(skipped),
        time=f"{sum(case.wall_s for case in cases):.3f}",
    )
    for case in cases:
        testcase = ET.SubElement(
            node,
            "testcase",
            classname="bywire.scenarios",
            name=case.name,
            time=f"{case.wall_s:.3f}",
        )
        if case.not_applicable is not None:
            ET.SubElement(testcase, "skipped", message=case.not_applicable)
        elif case.error is not None:
            ET.SubElement(
                testcase, "error", message=case.error, type="ConfigError"
            ).text = f"{case.origin}: {case.error}"
        elif not case.passed:
            reasons = case.reasons
            failure = ET.SubElement(
                testcase, "failure", message=f"{len(reasons)} expectation(s) failed"
            )
            failure.text = "\n".join(reasons)
        if case.summary is not None:
            ET.SubElement(testcase, "system-out").text = _outline(case.summary)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _outline(summary: Summary) -> str:
    lines = [f"{summary.simulated_s:.1f} s simulated"]
    lines += [f"{e.status.upper()}: {e.description}" for e in summary.expectations]
    return "\n".join(lines)
