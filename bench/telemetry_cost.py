"""What the telemetry feed costs the controller's loop: the tap's time per call, measured.

``python bench/telemetry_cost.py [--duration S] [--realtime]`` plays the trial run with the
feed recording to a temporary MCAP file (as ``bywire sim --mcap``: the writer a thread on virtual
time; with ``--realtime`` a process of its own, which the tap ships to after each pass)
and times, with ``time.perf_counter_ns``, every call the loop makes into the feed: the tap after
each pass (split into passes that queue a state capture and passes that only check for events)
and the bus monitor's ``can_frame``. The percentiles are of those calls; the figure excludes the
timing wrapper's own cost, measured separately and subtracted.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bywire.config import default_sim_config
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from bywire.telemetry.capture import Capture, TelemetryTap
from bywire.telemetry.feed import FeedOptions, open_feed
from bywire.telemetry.outbox import Outbox


def _percentiles(samples_ns: list[int], overhead_ns: float) -> str:
    ordered = sorted(max(s - overhead_ns, 0.0) for s in samples_ns)
    if not ordered:
        return "no calls"

    def at(fraction: float) -> float:
        return ordered[min(int(fraction * len(ordered)), len(ordered) - 1)] / 1000

    return (
        f"n={len(ordered):6d}  median {at(0.5):6.2f} µs  p99 {at(0.99):6.2f} µs"
        f"  max {ordered[-1] / 1000:7.2f} µs"
    )


def _timer_overhead_ns() -> float:
    """The cost of two perf_counter_ns calls and a list append, which every sample includes."""
    samples = []
    for _ in range(100_000):
        started = time.perf_counter_ns()
        samples.append(time.perf_counter_ns() - started)
    return statistics.median(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=40.0)
    parser.add_argument("--realtime", action="store_true")
    parser.add_argument(
        "--no-writer",
        action="store_true",
        help="queue captures but start no writer: the tap's own share, without the interpreter"
        " lock shared with a writer thread or the shipping to a writer process",
    )
    args = parser.parse_args()
    sim = SimRun(
        default_sim_config(),
        find_scenario("test-course"),
        realtime=args.realtime,
        duration_s=args.duration,
    )
    state_ns: list[int] = []
    event_only_ns: list[int] = []
    can_ns: list[int] = []
    with tempfile.TemporaryDirectory() as folder:
        options = FeedOptions(mcap_path=Path(folder) / "cost.mcap")
        with contextlib.ExitStack() as stack:
            if args.no_writer:
                outbox: Outbox[Capture] = Outbox(10**7)
                tap = TelemetryTap(sim.runtime, outbox).attach()
            else:
                feed = stack.enter_context(
                    open_feed(sim.runtime, options, virtual_time=not args.realtime)
                )
                tap, outbox = feed.tap, feed.outbox
            sim.runtime.on_cycle.remove(tap.observe)

            def observe(now: float) -> None:
                before = outbox.put_count
                started = time.perf_counter_ns()
                tap.observe(now)
                spent = time.perf_counter_ns() - started
                (state_ns if outbox.put_count > before else event_only_ns).append(spent)

            def timed(call: Callable[..., None]) -> Callable[..., None]:
                def wrapper(*a: object) -> None:
                    started = time.perf_counter_ns()
                    call(*a)
                    can_ns.append(time.perf_counter_ns() - started)

                return wrapper

            sim.runtime.on_cycle.append(observe)
            can_frame = timed(tap.can_frame)
            sim.add_can_monitor(lambda f: can_frame(f.time_s, f.arbitration_id, f.data, f.sender))
            sim.run()
        dropped = outbox.dropped
    overhead_ns = _timer_overhead_ns()
    clock = "real" if args.realtime else "virtual"
    writer = (
        "no writer"
        if args.no_writer
        else f"writer {'process' if args.realtime else 'thread'} recording an MCAP"
    )
    print(
        f"trial run, {args.duration:g} s on {clock} time, {writer};"
        f" timer overhead {overhead_ns:.0f} ns (subtracted)"
    )
    print(f"  pass with a state capture (and events): {_percentiles(state_ns, overhead_ns)}")
    print(f"  pass with events check only:            {_percentiles(event_only_ns, overhead_ns)}")
    print(f"  CAN frame (bus monitor):                {_percentiles(can_ns, overhead_ns)}")
    print(f"  captures dropped: {dropped}")


if __name__ == "__main__":
    main()
