"""The deploy tier: the README's commands and docs/DEPLOY.md's install block, read from the
markdown and typed line by line into a freshly booted Debian 12 (tests/deploy/commands.py says
what runs where; tests/deploy/machine.py makes the machine), end with `bywire run --check`
naming every device this machine lacks, and the service failing to start on the same.

Needs root, debootstrap and systemd-nspawn (Debian's systemd-container); `tests/deploy/run`
runs this module, as CI does after the other tiers. Elsewhere it skips with one line. Nothing
leaves this machine but Debian's and PyPI's package downloads (the online phase, which installs
packages); the robot's side runs in a private network namespace (loopback only).
"""

from __future__ import annotations

import os
import re
import shutil
import time
from dataclasses import dataclass

import pytest

from tests.deploy import commands, machine
from tests.deploy.commands import Step

ENABLE_HINT = (
    "deploy tier: run `tests/deploy/run` as root (with debootstrap and systemd-nspawn) to type"
    " the README's and docs/DEPLOY.md's commands into a fresh Debian (README, 'The deploy tier')"
)
if os.environ.get("BYWIRE_DEPLOY_TIER") != "1":
    pytest.skip(ENABLE_HINT, allow_module_level=True)

STEPS = commands.plan()
# Every device the robot file (config/albert.toml) names, as `bywire run --check` calls it.
DEVICES = (
    "GPIO output lines",
    "DAC",
    "steering PWM",
    "hydraulic brake PWM",
    "RC receiver (UART)",
    "CAN bus",
)
# What each device's line says this machine lacks (bywire run's refusal names the same).
MISSING = (
    "no chip 'pinctrl-bcm2711'",
    "/dev/i2c-1 does not exist",
    "no chip 'fe20c000.pwm'",
    "/dev/ttyAMA0 does not exist",
    "CAN socketcan can0",
)
# The only commands not run for real, and why (the stand-in is tests/deploy/udevadm).
STOOD_IN = {
    "udevadm control --reload": "no udevd in a container: the rules are loaded by `udevadm test`",
    "udevadm trigger": "no device events in a container: nothing to replay",
}


@dataclass
class Ended:
    status: int
    stopped: bool
    seconds: float
    output: str


@dataclass
class Run:
    started: set[int]
    ended: dict[int, Ended]
    seconds: dict[str, float]

    def of(self, step: Step) -> Ended:
        index = STEPS.index(step)
        if index in self.started:
            assert index in self.ended, (
                f"started, but the guest's boot ended before it did: {step.text}"
                f" (the guest's journal: BYWIRE_DEPLOY_KEEP=1, journalctl -D ROOT/var/log/journal)"
            )
        assert index in self.ended, f"never ran: {step.text}"
        return self.ended[index]


def _preflight() -> None:
    missing = [tool for tool in ("debootstrap", "systemd-nspawn") if shutil.which(tool) is None]
    if os.geteuid() != 0 or missing:
        pytest.fail(
            "deploy tier: needs root and debootstrap and systemd-nspawn (Debian: apt-get install"
            f" debootstrap systemd-container); missing: {', '.join(missing) or 'root'}"
        )


@pytest.fixture(scope="module")
def run() -> Run:
    _preflight()
    begun: set[int] = set()
    ended: dict[int, Ended] = {}
    seconds: dict[str, float] = {}

    def record(entry: dict[str, object]) -> None:
        index = int(str(entry["index"]))
        step = STEPS[index]
        where = f"[{step.phase}, {step.user}, {step.source}]"
        if entry["event"] == "start":
            begun.add(index)
            print(f"deploy tier: {where} $ {step.text}", flush=True)
            return
        done = Ended(
            int(str(entry["status"])),
            bool(entry["stopped"]),
            float(str(entry["seconds"])),
            str(entry["output"]),
        )
        ended[index] = done
        how = "stopped by Ctrl-C, " if done.stopped else ""
        print(f"deploy tier:   {how}exit {done.status} in {done.seconds:.1f} s", flush=True)

    started = time.monotonic()
    tarball, made = machine.base_tarball()
    seconds["base made" if made else "base from cache"] = time.monotonic() - started
    with machine.fresh_root(tarball) as root:
        commit = machine.prepare(root, STEPS)
        print(f"deploy tier: guest ready, clone of {commit[:12]} at {commands.REMOTE_IN_GUEST}")
        seconds["guest ready"] = time.monotonic() - started
        for phase in ("online", "offline"):
            seconds[f"{phase} boot"] = machine.boot(root, phase, record)
    seconds["total"] = time.monotonic() - started
    print("deploy tier: " + ", ".join(f"{name} {s:.0f} s" for name, s in seconds.items()))
    return Run(begun, ended, seconds)


def _step(source: str, pattern: str) -> Step:
    found = [step for step in STEPS if step.source == source and re.search(pattern, step.text)]
    assert len(found) == 1, (pattern, found)
    return found[0]


def _docs_steps() -> list[Step]:
    return [step for step in STEPS if step.source != "tier"]


@pytest.mark.parametrize("step", STEPS, ids=lambda step: step.text[:60])
def test_each_line_ends_as_expected(run: Run, step: Step) -> None:
    ended = run.of(step)
    if step.expect is None:
        assert ended.stopped, ended.output  # ran until the tier's Ctrl-C
    else:
        assert (ended.status, ended.stopped) == (step.expect, False), ended.output


def test_run_check_names_every_missing_device_and_exits_2(run: Run) -> None:
    ended = run.of(_step("docs/DEPLOY.md", commands.RUN_CHECK))
    assert ended.status == 2, ended.output
    problems = [line for line in ended.output.splitlines() if line.startswith("PROBLEM")]
    for device in DEVICES:
        assert any(line.split(None, 1)[1].startswith(f"{device}:") for line in problems), device
    for what in MISSING:
        assert what in ended.output, what
    assert re.search(rf"\b0 of {len(DEVICES)} devices ready", ended.output), ended.output


def test_bywire_run_refuses_to_start_naming_the_same_devices(run: Run) -> None:
    ended = run.of(_step("docs/DEPLOY.md", commands.RUN))
    assert ended.output.startswith("bywire run: error:"), ended.output
    for what in MISSING:
        assert what in ended.output, what


def test_the_service_fails_its_start_on_the_devices_and_is_not_restarted(run: Run) -> None:
    journal = run.of(_step("docs/DEPLOY.md", commands.FOLLOW_JOURNAL)).output
    assert "bywire run: error:" in journal, journal
    for what in MISSING:
        assert what in journal, what
    shown = run.of(_step("tier", r"^systemctl show bywire")).output
    # exit 2 is RestartPreventExitStatus: a configuration or device problem is not restarted
    for setting in ("ActiveState=failed", "Result=exit-code", "ExecMainStatus=2", "NRestarts=0"):
        assert setting in shown.splitlines(), shown


def test_the_service_user_has_the_device_groups(run: Run) -> None:
    ended = run.of(_step("tier", r"^id bywire$"))
    groups = set(re.findall(r"\d+\((\w+)\)", ended.output.split("groups=")[1]))
    assert {"bywire", "dialout", "i2c", "gpio", "plugdev"} <= groups, ended.output


def test_systemd_networkd_runs_with_the_can_network_file_and_no_complaint(run: Run) -> None:
    assert run.of(_step("tier", r"is-active systemd-networkd")).output.strip() == "active"
    journal = run.of(_step("tier", r"journalctl -b -u systemd-networkd")).output
    assert "80-can.network" not in journal, journal  # networkd names a file it cannot parse


def test_the_readme_runs_the_simulator_and_every_expectation_passes(run: Run) -> None:
    run_command = commands.readme_commands()[0][1]
    ended = run.of(_step("README.md", re.escape(run_command)))
    passed = re.search(r"(\d+) of (\d+) expectations passed", ended.output)
    assert passed is not None, ended.output
    assert passed[1] == passed[2], passed[0]


def test_the_readme_test_command_installs_and_runs_the_subset(run: Run) -> None:
    test_command = commands.readme_commands()[1][1]
    ended = run.of(_step("README.md", re.escape(test_command)))
    summary = ended.output.strip().splitlines()[-1]
    assert re.fullmatch(r"=* ?\d+ passed in [\d.]+s ?=*", summary), summary


def test_only_udevadm_was_stood_in_for_and_the_rules_loaded(run: Run) -> None:
    udev_step = _step("docs/DEPLOY.md", r"udevadm control --reload")
    udev = run.of(udev_step)
    lines = [line for line in udev.output.splitlines() if "deploy tier stand-in" in line]
    assert len(lines) == len(STOOD_IN), udev.output
    assert "without a complaint" in lines[0], udev.output
    stood_in = [
        step.text for step in _docs_steps() if "deploy tier stand-in" in run.of(step).output
    ]
    assert stood_in == [udev_step.text], stood_in
    print("deploy tier: stood in for: " + "; ".join(f"{k} ({v})" for k, v in STOOD_IN.items()))
