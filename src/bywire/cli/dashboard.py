"""`bywire dashboard`: the controller on the simulated robot in real time, with its live view."""

from __future__ import annotations

import argparse
from pathlib import Path

from bywire.cli.arguments import positive_seconds
from bywire.config import default_sim_config, load_config
from bywire.dashboard.live import LiveRun
from bywire.sim.catalog import DEFAULT_SCENARIO, find_scenario
from bywire.sim.runner import SimRun

EPILOG = """\
The controller runs in a background thread, paced by the wall clock; the view shows its mode and
latch, error flags by name, the selected movement command and its source, the actuator outputs,
input ages and counts, and the task table (the counterpart of the thesis' Figure 30): measured
rate, runtime share, start jitter p99/max, overruns and budget overruns, and the idle share.
When the scenario ends the last picture stays on screen. q quits: the controller stops and
writes its safe outputs.

examples:
  bywire dashboard                          # the test course (40 s)
  bywire dashboard --scenario rc-link-lost  # watch RC_TIMEOUT latch STOP
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        metavar="NAME|FILE",
        help=f"packaged scenario (`bywire sim --list`) or a file (default {DEFAULT_SCENARIO})",
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        metavar="S",
        help="seconds to run (default: the scenario's)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="robot configuration TOML (default: the packaged simulator defaults)",
    )


def build(args: argparse.Namespace) -> LiveRun:
    """The live run for the arguments (not started); ConfigError for a bad scenario or config."""
    robot = default_sim_config() if args.config is None else load_config(args.config)
    scenario = find_scenario(args.scenario)
    return LiveRun(SimRun(robot, scenario, realtime=True, duration_s=args.duration))


def run(args: argparse.Namespace) -> int:
    """Start the controller, show the dashboard until `q`, stop the controller."""
    live = build(args)
    live.start()
    try:
        run_app(live)
    finally:
        live.stop()
    return 0


def run_app(live: LiveRun) -> None:
    """The textual program (imported here: textual is only needed by this command)."""
    from bywire.dashboard.app import DashboardApp  # noqa: PLC0415 -- keeps `bywire --help` fast

    DashboardApp(live.feed, source=f"scenario {live.sim.scenario.name}", on_exit=live.stop).run()
