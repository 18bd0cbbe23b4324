"""The differential check: what the simulated hardware did, run by run, bit for bit.

A speed-up of the simulator or the controller must not change what the robot does. This script
plays every packaged scenario that runs on virtual time and 30 `bywire verify` campaigns of a
fixed seed, and records every output the hardware saw: each GPIO line's and PWM channel's change
history and write count, the DAC's history and write counts, every frame that crossed the CAN
bus (commands and reports, with their times), and the verdicts, oracle findings and supervisor
transitions of the run. `check` compares their digests with those stored beside it
(`differential.json`); about two minutes on one core, too long for CI, so it is run by hand
before and after each change meant to be faster, not different.

Looking must not change the run either: each scenario is played a second time with every file
`bywire sim` can write attached as the command attaches it (`--record`, `--mcap`, `--log`), and
that run must match the plain run's stored digest; the record it wrote must replay identically
(`bywire replay`). These runs have no digests of their own (`NAME+files`).

    python bench/differential.py check           # exit 1 naming each run that diverged
    python bench/differential.py dump DIR        # every run's full history, one JSON each
    python bench/differential.py compare DIR     # the first difference of each run from a dump
    python bench/differential.py digests         # store new digests (a change of behaviour)

Authenticated runs sign with the key drawn from the simulator's seed (`simulated_run_key`), so that
they repeat.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import hashlib
import json
import sys
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from bywire.canlog.write import CanLog
from bywire.cli.sim import attach_feed
from bywire.config import RobotConfig, default_sim_config
from bywire.config.speed_limit import LimitsSection
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.tape.run_record import read_record
from bywire.replay.recorder import SimRunRecorder
from bywire.replay.runner import replay
from bywire.sim.catalog import packaged_scenarios
from bywire.sim.runner import SimRun, run_clock
from bywire.sim.verify.campaign import Campaign, compile_steps
from bywire.sim.verify.draw import draw_campaign
from bywire.telemetry.feed import FeedOptions, open_sinks

DIGESTS = Path(__file__).with_name("differential.json")
CAMPAIGN_SEED = 12
CAMPAIGNS = 30
WITH_FILES = "+files"  # the same run with every file written: the plain run's digest


History = dict[str, Any]


class _Recorder:
    """Attached to a run before it starts: keeps every CAN frame; reads the rest at the end."""

    def __init__(self, run: SimRun) -> None:
        self.run = run
        self.frames: list[list[object]] = []
        run.add_can_monitor(self._frame)

    def _frame(self, frame: LoggedFrame) -> None:
        self.frames.append([frame.time_s, frame.arbitration_id, frame.data.hex(), frame.sender])

    def history(self) -> History:
        world = self.run.world
        return {
            "gpio": {
                name: [[list(entry) for entry in line.history], line.writes]
                for name, line in sorted(world.gpio.items())
            },
            "pwm": {
                channel.name: [[list(entry) for entry in channel.history], channel.writes]
                for channel in (world.pwm.steering, world.pwm.hydrobrake)
            },
            "dac": [
                [list(entry) for entry in world.dac.history],
                world.dac.writes,
                world.dac.failed_writes,
            ],
            "can": self.frames,
            "verdicts": [[v.passed, v.measured_s] for v in self.run.record.verdicts],
        }


def scenario_history(robot: RobotConfig, name: str) -> History:
    """A packaged scenario played on virtual time."""
    run = SimRun(robot, packaged_scenarios()[name])
    recorder = _Recorder(run)
    run.run()
    return recorder.history()


def scenario_history_with_files(robot: RobotConfig, name: str) -> History:
    """The same scenario with a run record, an MCAP file and a CAN log written as `bywire sim
    --record --mcap --log` writes them; the record's replay, if it diverges, is added (so the
    digest differs from the plain run's)."""
    with tempfile.TemporaryDirectory() as folder, contextlib.ExitStack() as stack:
        files = Path(folder)
        scenario = packaged_scenarios()[name]
        clock = run_clock(scenario)
        options = FeedOptions(mcap_path=files / "run.mcap")
        sinks = stack.enter_context(open_sinks(options, clock, virtual_time=True))  # as sim's
        run = SimRun(robot, scenario, clock=clock)
        record = SimRunRecorder.attach(run, files / "run.jsonl")
        recorder = _Recorder(run)
        run.add_can_monitor(stack.enter_context(CanLog(files / "run.blf", run.started_at)))
        attach_feed(stack, run, sinks, options)
        run.run()
        stack.close()
        record.write()
        history = recorder.history()
        divergence = replay(read_record(files / "run.jsonl")).divergence
        if divergence is not None:
            history["replay"] = divergence.describe()
        return history


def campaign_history(robot: RobotConfig, index: int) -> History:
    """Campaign `index` of the fixed seed, played with the hazard oracle watching."""
    recorders: list[_Recorder] = []
    scenario = compile_steps(draw_campaign(CAMPAIGN_SEED, index), robot)
    result = Campaign(robot).run_scenario(scenario, lambda run: recorders.append(_Recorder(run)))
    history = recorders[0].history()
    history["findings"] = [[v.invariant, v.time_s, v.detail] for v in result.oracle.violations]
    history["transitions"] = sorted(result.transitions)
    return history


def _scenario_history(name: str, robot: RobotConfig) -> History:
    return scenario_history(robot, name)


def _scenario_history_with_files(name: str, robot: RobotConfig) -> History:
    return scenario_history_with_files(robot, name)


def _campaign_history(index: int, robot: RobotConfig) -> History:
    return campaign_history(robot, index)


def runs() -> dict[str, Callable[[RobotConfig], History]]:
    """Every run of the check by name: the virtual-time scenarios, then the campaigns."""
    table: dict[str, Callable[[RobotConfig], History]] = {}
    for name, scenario in packaged_scenarios().items():
        if not scenario.realtime:
            table[f"scenario:{name}"] = functools.partial(_scenario_history, name)
            table[f"scenario:{name}{WITH_FILES}"] = functools.partial(
                _scenario_history_with_files, name
            )
    for index in range(CAMPAIGNS):
        table[f"campaign:{index}"] = functools.partial(_campaign_history, index)
    return table


def canonical(history: History) -> str:
    """The history as one string: floats in Python's shortest exact form, keys sorted."""
    return json.dumps(history, sort_keys=True, separators=(",", ":"))


def digest(history: History) -> str:
    return hashlib.sha256(canonical(history).encode()).hexdigest()


def stored_digests() -> dict[str, str]:
    loaded: dict[str, str] = json.loads(DIGESTS.read_text(encoding="utf-8"))
    return loaded


def _first_difference(path: str, before: object, after: object) -> str | None:
    """Where two histories first differ, as a path into them and the two values."""
    if isinstance(before, dict) and isinstance(after, dict):
        for key in sorted(set(before) | set(after)):
            found = _first_difference(f"{path}.{key}", before.get(key), after.get(key))
            if found is not None:
                return found
        return None
    if isinstance(before, list) and isinstance(after, list):
        for index, (old, new) in enumerate(zip(before, after, strict=False)):
            found = _first_difference(f"{path}[{index}]", old, new)
            if found is not None:
                return found
        if len(before) != len(after):
            return f"{path}: {len(before)} entries before, {len(after)} now"
        return None
    return None if before == after else f"{path}: {before!r} before, {after!r} now"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="python bench/differential.py")
    parser.add_argument("action", choices=("check", "dump", "compare", "digests"))
    parser.add_argument("folder", nargs="?", type=Path)
    args = parser.parse_args(argv)
    return _act(args, bench_robot())


def bench_robot() -> RobotConfig:
    """The simulator's defaults without their speed limit (issue 44): the stored digests were
    taken before the controller had one, and the packaged defaults now set one. The runs that
    need the limit (`speed-limit-slope`) are recorded without it too: what the hardware did, not
    a verdict."""
    return replace(default_sim_config(), limits=LimitsSection(None))


def _act(args: argparse.Namespace, robot: RobotConfig) -> int:
    digests: dict[str, str] = {}
    stored = stored_digests() if args.action == "check" else {}
    differing = 0
    for name, play in runs().items():
        history = play(robot)
        digests[name] = digest(history)
        file = None if args.folder is None else args.folder / (name.replace(":", "-") + ".json")
        if args.action == "check" and digests[name] != stored.get(name.removesuffix(WITH_FILES)):
            differing += 1
            print(f"{name}: DIVERGED (dump before and after, then compare, to see where)")
        elif args.action == "dump" and file is not None:
            args.folder.mkdir(parents=True, exist_ok=True)
            file.write_text(canonical(history), encoding="utf-8")
        elif args.action == "compare" and file is not None:
            before = json.loads(file.read_text(encoding="utf-8"))
            found = _first_difference(name, before, json.loads(canonical(history)))
            differing += found is not None
            print(found or f"{name}: identical")
    own = {name: value for name, value in digests.items() if not name.endswith(WITH_FILES)}
    if args.action == "digests":
        DIGESTS.parent.mkdir(parents=True, exist_ok=True)
        DIGESTS.write_text(json.dumps(own, indent=1) + "\n", encoding="utf-8")
    if args.action == "check":
        missing = sorted(set(stored) ^ set(own))
        differing += len(missing)
        for name in missing:
            print(f"{name}: in only one of the stored digests and this run")
        print(f"{len(digests) - differing} of {len(digests)} runs identical")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
