"""Same verdicts: the rebuilt oracle (`bywire.sim.verify.oracle`) against the old one-class oracle,
watching the very same runs.

The old `sim/oracle.py` and its witness (the old `sim/campaign.py`'s `OracleWitness`) are read
from git at `--base` (by default the newest commit that changed `sim/oracle.py` and has it) and
loaded under other module names. Each campaign (`bywire verify`'s `draw_campaign(seed, index)`)
is run once, on the simulated robot, with both oracles and both witnesses attached: every pass
is judged by both, and their violations (invariant, time, detail, expected levels) must be
identical, run by run. Runs are drawn on the correct robot and with old safety bugs put back
(`tests/system/old_bugs.py`), so that there are violations to compare.

    PYTHONPATH=. .venv/bin/python bench/oracle_same_verdicts.py --campaigns 25

Exit 1 if any run's verdicts differ (each such run is printed with its first difference).
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import time
import types
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, cast

import pytest
from tests.sim.verify.test_verify import OTHER_ROBOTS
from tests.system.old_bugs import OLD_BUGS

from bywire.config import RobotConfig, default_sim_config, load_config, parse_config
from bywire.hal.simulated.clock import VirtualClock
from bywire.sim.runner import SimRun
from bywire.sim.verify.actions import compile_steps
from bywire.sim.verify.campaign import _quiet_runtime
from bywire.sim.verify.draw import draw_campaign
from bywire.sim.verify.oracle import HazardOracle, OracleTiming
from bywire.sim.verify.witness import OracleWitness

ROOT = Path(__file__).resolve().parent.parent
OLD_ORACLE = "src/bywire/sim/oracle.py"
OLD_CAMPAIGN = "src/bywire/sim/campaign.py"
BUGS = (
    "row_23_a_can_re_enable_clears_every_cause",
    "row_4_a_handover_without_the_throttle_gate",
    "hazard_6_stop_spares_the_hydraulic_brake",
    "hazard_20_throttle_beats_brake",
    "hazard_19_the_interlock_takes_the_robot_for_standing",
    "issue_30_the_steering_takes_over_at_once",
    "stop_centres_the_steering",
    "row_7_only_consecutive_dac_failures_count",
)
"""Old bugs whose campaigns break H1, H2, H4, H5, H6 and H9: violations to compare."""

Verdict = tuple[str, float, str, dict[str, Any]]


def _git(*args: str) -> str:
    return subprocess.run(
        ["git", *args], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout


def default_base() -> str:
    """The last commit with the old oracle: the newest that changed it and still has it (its
    deleting commit has not; a later change merged from another branch has)."""
    for commit in _git("log", "--full-history", "--format=%H", "--", OLD_ORACLE).split():
        exists = subprocess.run(
            ["git", "cat-file", "-e", f"{commit}:{OLD_ORACLE}"],
            cwd=ROOT,
            capture_output=True,
            check=False,
        )
        if exists.returncode == 0:
            return commit
    raise SystemExit(f"no commit has {OLD_ORACLE}: give --base")


def _load(name: str, source: str) -> types.ModuleType:
    spec = importlib.util.spec_from_loader(name, loader=None)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the class is built
    exec(compile(source, f"<{name}>", "exec"), module.__dict__)
    return module


@dataclass(frozen=True, slots=True)
class OldJudge:
    """The old oracle's module and its campaign module (for its `OracleWitness`)."""

    oracle: types.ModuleType
    campaign: types.ModuleType

    @classmethod
    def at(cls, base: str) -> OldJudge:
        oracle = _load("old_bywire_oracle", _git("show", f"{base}:{OLD_ORACLE}"))
        campaign_source = _git("show", f"{base}:{OLD_CAMPAIGN}").replace(
            "from bywire.sim.oracle import", "from old_bywire_oracle import"
        )
        return cls(oracle, _load("old_bywire_campaign", campaign_source))


def _verdicts(violations: list[Any]) -> list[Verdict]:
    return [(str(v.invariant), v.time_s, v.detail, dict(v.expected)) for v in violations]


def judge_both(
    old: OldJudge, robot: RobotConfig, seed: int, index: int
) -> tuple[list[Verdict], list[Verdict]]:
    """Campaign `index` of `seed` on `robot`, judged by the old and the new oracle at once."""
    scenario = compile_steps(draw_campaign(seed, index), robot)
    run = SimRun(robot, scenario)
    clock = cast(VirtualClock, run.world.clock)
    dac = robot.drive.dac
    new_oracle = HazardOracle(run.world, OracleTiming.for_robot(robot))
    old_oracle = old.oracle.HazardOracle(
        run.world,
        dac.throttle_channel,
        dac.regen_channel,
        timing=old.oracle.OracleTiming.for_robot(robot),
    )
    run.on_event.append(OracleWitness(new_oracle, clock, scenario.authenticated))
    run.on_event.append(old.campaign.OracleWitness(old_oracle, clock, scenario.authenticated))
    run.on_exit.append(new_oracle.exited)
    run.on_exit.append(old_oracle.exited)
    run.runtime.on_cycle.append(new_oracle.observe)
    run.runtime.on_cycle.append(old_oracle.observe)
    with _quiet_runtime():
        run.run()
    assert new_oracle.checks == old_oracle.checks > 0
    return _verdicts(old_oracle.violations), _verdicts(new_oracle.violations)


@contextmanager
def _bug(name: str | None) -> Iterator[None]:
    with pytest.MonkeyPatch.context() as monkeypatch:
        if name is not None:
            OLD_BUGS[name](monkeypatch)
        yield


def settings(
    albert: Path,
) -> list[tuple[str, Callable[[], RobotConfig], str | None]]:
    """(label, robot, bug) of every setting compared."""
    robots: list[tuple[str, Callable[[], RobotConfig], str | None]] = [
        ("sim robot", default_sim_config, None),
        ("albert.toml", lambda: load_config(albert), None),
    ]
    robots += [
        (name, partial(parse_config, f'backend = "sim"\n\n{text}', f"<{name}>"), None)
        for name, text in OTHER_ROBOTS.items()
    ]
    robots += [(f"sim robot + {bug}", default_sim_config, bug) for bug in BUGS]
    return robots


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="the commit with the old oracle (default: found in git)")
    parser.add_argument("--campaigns", type=int, default=25, help="campaigns per setting")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", default="", help="only the settings whose label has this")
    args = parser.parse_args(argv)
    base = args.base or default_base()
    old = OldJudge.at(base)
    print(f"old oracle: {OLD_ORACLE} at {_git('rev-parse', '--short', base).strip()}")
    runs = differing = 0
    flagged_old = flagged_new = violations_old = 0
    started = time.monotonic()
    for label, robot_of, bug in settings(ROOT / "config" / "albert.toml"):
        if args.only not in label:
            continue
        robot = robot_of()
        found = 0
        with _bug(bug):
            for index in range(args.campaigns):
                old_verdicts, new_verdicts = judge_both(old, robot, args.seed, index)
                runs += 1
                flagged_old += bool(old_verdicts)
                flagged_new += bool(new_verdicts)
                violations_old += len(old_verdicts)
                found += len(old_verdicts)
                if old_verdicts != new_verdicts:
                    differing += 1
                    first = next(
                        (
                            pair
                            for pair in zip(old_verdicts, new_verdicts, strict=False)
                            if pair[0] != pair[1]
                        ),
                        (
                            old_verdicts[len(new_verdicts) :][:1],
                            new_verdicts[len(old_verdicts) :][:1],
                        ),
                    )
                    print(f"  DIFFERENT {label}, campaign {index} of seed {args.seed}: {first}")
        print(f"{label}: {args.campaigns} campaigns, {found} violations (old)", flush=True)
    print(
        f"{runs} runs in {time.monotonic() - started:.0f} s: {runs - differing} identical,"
        f" {differing} different; runs flagged old {flagged_old} / new {flagged_new};"
        f" {violations_old} violations compared"
    )
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
