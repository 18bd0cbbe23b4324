"""`bywire replay RECORD`: run the controller again on a recorded run's inputs, compare outputs.

Exit 0 when every output is identical, 1 at the first output that differs (its time, its name,
the recorded and the replayed value), 2 for a file that is not a run record.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bywire.canlog.read import SUFFIXES
from bywire.config import load_config
from bywire.errors import ConfigError
from bywire.hal.tape.run_record import read_record
from bywire.replay.divergence import dac_volts
from bywire.replay.runner import recorded_robot, replay


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "record", type=Path, metavar="RECORD", help="run record written by `bywire sim --record`"
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="robot configuration TOML to replay with (default: the one recorded)",
    )
    parser.add_argument("--json", action="store_true", help="print the verdict as JSON")


def run(args: argparse.Namespace) -> int:
    path: Path = args.record
    if path.suffix.lower() in SUFFIXES:
        raise ConfigError(
            f"{path.name} is a CAN log, which lacks the RC input and the sensors:"
            " replay needs a run record (bywire sim --record FILE.jsonl)"
        )
    robot = None if args.config is None else load_config(args.config)
    record = read_record(path)
    result = replay(record, robot)
    divergence, start_s = result.divergence, record.header.start_s
    vref_volts = (robot or recorded_robot(record)).drive.dac.vref_volts
    if args.json:
        verdict: dict[str, object] = {
            "identical": divergence is None,
            "outputs": len(result.recorded),
        }
        if divergence is not None:
            diverged: dict[str, object] = {
                "time_s": divergence.time_s - start_s,
                "output": divergence.name,
                "recorded": divergence.recorded,
                "replayed": divergence.replayed,
                "recorded_writes": list(divergence.recorded_writes),  # that output's, that instant
                "replayed_writes": list(divergence.replayed_writes),
                "description": divergence.describe(start_s, vref_volts),
            }
            if divergence.name.startswith("dac."):
                diverged["recorded_volts"] = dac_volts(divergence.recorded or "", vref_volts)
                diverged["replayed_volts"] = dac_volts(divergence.replayed or "", vref_volts)
            verdict["divergence"] = diverged
        print(json.dumps(verdict, indent=2))
    elif divergence is None:
        span_s = record.header.end_s - start_s
        print(
            f"{len(result.recorded)} outputs identical"
            f" ({record.header.scenario}, {span_s:g} s replayed)"
        )
    else:
        print(f"replay of {path.name}: {divergence.describe(start_s, vref_volts)}")
    return 0 if divergence is None else 1
