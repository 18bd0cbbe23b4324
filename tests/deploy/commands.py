"""What the deploy tier types: the commands of the README and of docs/DEPLOY.md's install block,
read from the markdown itself (never retyped, so the docs cannot drift from what is tested), and
what each must end with.

The plan, in the order a person would go:

- online (the container shares this machine's network, for Debian's and PyPI's packages only):
  docs/DEPLOY.md's install block up to its last line that installs packages (`apt-get install`,
  `pip install`), then a developer (`dev`) on the same machine: a clone of their own, and the
  README's two commands, each after the `sudo apt-get install …` its paragraph says to run first
  on Debian (as root: `dev` is no sudoer);
- offline (a private network: loopback only, as a robot with its Ethernet unplugged): the rest of
  the install block, to the service, its journal and the tier's look at what they left.

Lines the docs expect to fail on a machine without the robot's hardware are listed in
`EXPECTED_FAILURES` by a pattern that must match exactly one line (tests/deploy/test_commands.py
holds that), with the exit status they must end with; every other line must exit 0.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DEPLOY = ROOT / "docs" / "DEPLOY.md"

# Where the tier's clone of this checkout lies in the guest; the docs' clone line reads it from
# $BYWIRE_REMOTE, the placeholder docs/DEPLOY.md asks the reader to set.
REMOTE_IN_GUEST = "/srv/bywire.git"
REMOTE_VARIABLE = "BYWIRE_REMOTE"
DEVELOPER = "dev"
DEVELOPER_CLONE = f"/home/{DEVELOPER}/bywire"

# The README's test command runs as written; the suite is narrowed through pytest's own
# PYTEST_ADDOPTS to the `--check` of the Linux backends and the systemd unit's checks (which
# need systemd-analyze, there on that machine): the whole suite takes 6-10 minutes.
PYTEST_SUBSET = (
    "-p no:cacheprovider"
    " tests/cli/test_run.py::test_check_names_each_problem_and_exits_2"
    " tests/deploy/test_unit.py"
)

ONLINE_MARKERS = ("apt-get install", "pip install")

# The install block's lines the tier looks at closely, by a pattern matching exactly one line.
RUN_CHECK = r"bywire run --config /etc/bywire/robot\.toml --check"  # the pre-arm check
RUN = r"bywire run --config /etc/bywire/robot\.toml(?! --check)"  # the controller itself
START_SERVICE = r"systemctl enable --now bywire$"
FOLLOW_JOURNAL = r"^journalctl -u bywire -f$"

# pattern -> the exit status its line must end with
EXPECTED_FAILURES: dict[str, int] = {
    RUN_CHECK: 2,  # every device missing on this machine
    RUN: 2,  # refuses to start on the same devices
    START_SERVICE: 1,  # bywire exits 2, so `systemctl enable --now` reports the failed start
}
# pattern -> seconds after which the tier presses Ctrl-C (a line that runs until stopped)
INTERRUPTED: dict[str, float] = {
    FOLLOW_JOURNAL: 5.0,
}

# What the tier itself runs in the guest, marked as its own: the developer's clone, and a look
# at what the install left (users, the service's end, systemd-networkd).
CLONE_FOR_DEVELOPER = f'git clone "${REMOTE_VARIABLE}" {DEVELOPER_CLONE}'
INSPECTIONS = (
    "id bywire",
    "systemctl show bywire -p ActiveState -p Result -p ExecMainStatus -p NRestarts",
    "systemctl is-active systemd-networkd",
    "journalctl -b -u systemd-networkd --no-pager -o cat",
    "ls -l /etc/bywire /var/lib/bywire",
)


@dataclass(frozen=True)
class Step:
    """One line typed into the guest."""

    source: str  # "README.md", "docs/DEPLOY.md" or "tier" (the tier's own, not the docs')
    text: str  # the line, verbatim
    phase: str  # "online" or "offline"
    user: str = "root"
    cwd: str = ""  # where the line starts; "" = where that user's last line ended (home first)
    expect: int | None = 0  # exit status; None: stopped by the tier (Ctrl-C) after interrupt_s
    interrupt_s: float | None = None
    env: dict[str, str] = field(default_factory=dict)


def shell_blocks(markdown: str) -> list[tuple[int, str]]:
    """Each fenced shell block (```sh, ```bash, ```console or bare ```): where it starts, its
    text."""
    pattern = re.compile(r"```(?:sh|bash|console)?\n(.*?)```", re.DOTALL)
    return [(match.start(), match.group(1)) for match in pattern.finditer(markdown)]


def command_lines(block: str) -> list[str]:
    """A block's lines that do something: blank and comment-only lines are left out."""
    lines = (line.strip() for line in block.splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def readme_commands(markdown: str | None = None) -> list[tuple[str, str]]:
    """The README's first two commands (run it; run the tests), each with what its paragraph
    says to install first on Debian ("" if nothing): [(prerequisite, command), ...]."""
    text = README.read_text(encoding="utf-8") if markdown is None else markdown
    found: list[tuple[str, str]] = []
    prose_start = 0
    for start, block in shell_blocks(text)[:2]:
        prose = text[prose_start:start]
        first = re.findall(r"first\s+`(sudo apt-get install [^`]+)`", prose)
        found.append((first[-1] if first else "", " ".join(command_lines(block))))
        prose_start = start + len(block)
    return found


def install_block(markdown: str | None = None) -> list[str]:
    """docs/DEPLOY.md's install block (the first shell block of its "## Install" section)."""
    text = DEPLOY.read_text(encoding="utf-8") if markdown is None else markdown
    if "\n## Install\n" not in text:
        raise ValueError("docs/DEPLOY.md: no '## Install' section to read the commands from")
    section = text[text.index("\n## Install\n") :]
    section = section[: section.find("\n## ", 1)]
    blocks = shell_blocks(section)
    if not blocks:
        raise ValueError("docs/DEPLOY.md: no shell block in its '## Install' section")
    return command_lines(blocks[0][1])


def _matching(patterns: dict[str, float] | dict[str, int], line: str) -> str | None:
    return next((pattern for pattern in patterns if re.search(pattern, line)), None)


def _install_step(line: str, phase: str) -> Step:
    failing = _matching(EXPECTED_FAILURES, line)
    interrupted = _matching(INTERRUPTED, line)
    if interrupted is not None:
        return Step(
            "docs/DEPLOY.md", line, phase, expect=None, interrupt_s=INTERRUPTED[interrupted]
        )
    expect = 0 if failing is None else EXPECTED_FAILURES[failing]
    return Step("docs/DEPLOY.md", line, phase, expect=expect)


def plan() -> list[Step]:
    """Every line the tier types, in order."""
    install = install_block()
    last_online = max(
        index for index, line in enumerate(install) if any(m in line for m in ONLINE_MARKERS)
    )
    steps = [_install_step(line, "online") for line in install[: last_online + 1]]
    steps.append(Step("tier", CLONE_FOR_DEVELOPER, "online", user=DEVELOPER))
    run, test = readme_commands()
    for (first, command), extra in ((run, {}), (test, {"PYTEST_ADDOPTS": PYTEST_SUBSET})):
        if first:
            steps.append(Step("README.md", first, "online"))
        steps.append(
            Step("README.md", command, "online", user=DEVELOPER, cwd=DEVELOPER_CLONE, env=extra)
        )
    steps += [_install_step(line, "offline") for line in install[last_online + 1 :]]
    steps += [Step("tier", text, "offline", cwd="/") for text in INSPECTIONS]
    return steps
