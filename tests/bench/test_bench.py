"""`bywire bench`: percentiles, latency pairing, the virtual-time session, JSON and the CLI.

No test here asserts how fast anything is: the figures belong in the benchmark, and the machines
that run the tests are shared and noisy. What is checked is the logic that produces the figures.
"""

from __future__ import annotations

import contextlib
import gc
import io
import itertools
import json
import math
from pathlib import Path

import pytest
from rich.console import Console

from bywire.bench.clocks import MeteredVirtualClock
from bywire.bench.figures import BenchResult, Figure, all_figures, as_json
from bywire.bench.latency import (
    DacWrite,
    SentCommand,
    ThrottleOutput,
    can_command,
    pair_writes,
    rc_command,
)
from bywire.bench.machine import cpu_model, machine_info
from bywire.bench.phases import in_span
from bywire.bench.realtime_session import BenchSettings, RealtimeResult, RealtimeSession
from bywire.bench.stats import percentile, summarise
from bywire.bench.sweeps import SWEEP_LEVELS, sawtooth_norm
from bywire.bench.table import format_value, render, summary_line
from bywire.bench.virtual import measure_speedup, measure_verify_rate
from bywire.cli.console import stdout_console
from bywire.cli.main import main
from bywire.config import default_sim_config
from bywire.control.drive import DriveConfig
from bywire.model import Gear, MovementCommand
from bywire.protocol import dac6574, dbc

PHASE_S = 2.0
SETTLE_S = 0.2
TOLERANCE_VOLTS = 5.0 / 2048

# --- percentiles ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fraction", "expected"), [(0.01, 1), (0.5, 50), (0.99, 99), (0.995, 100), (1.0, 100)]
)
def test_percentile_is_nearest_rank(fraction: float, expected: int) -> None:
    values = [float(v) for v in reversed(range(1, 101))]  # unsorted on purpose
    assert percentile(values, fraction) == expected


def test_percentile_survives_float_rounding_of_the_rank() -> None:
    # 0.99 * 1500 is 1485.0000000000002 in floats: the rank must still be 1485.
    assert percentile([float(v) for v in range(1, 1501)], 0.99) == 1485


def test_percentile_of_one_value_is_that_value() -> None:
    assert percentile([0.25], 0.5) == percentile([0.25], 0.99) == 0.25


@pytest.mark.parametrize(("values", "fraction"), [([], 0.5), ([1.0], 0.0), ([1.0], 1.5)])
def test_percentile_refuses_no_values_and_bad_fractions(
    values: list[float], fraction: float
) -> None:
    with pytest.raises(ValueError, match=r"percentile|fraction"):
        percentile(values, fraction)


def test_summary_of_no_latencies_has_no_figures_but_counts_the_unpaired() -> None:
    summary = summarise([], unpaired=3)
    assert (summary.samples, summary.unpaired) == (0, 3)
    assert summary.p50_s is summary.p99_s is summary.max_s is None


def test_summary_gives_p50_p99_and_max() -> None:
    summary = summarise([0.001 * v for v in range(1, 201)])
    assert summary.samples == 200
    assert summary.p50_s == pytest.approx(0.100)
    assert summary.p99_s == pytest.approx(0.198)
    assert summary.max_s == pytest.approx(0.200)


# --- pairing -------------------------------------------------------------------------------------


def test_each_command_is_paired_with_the_first_write_of_its_value_after_it() -> None:
    commands = [SentCommand(1.000, 1.0), SentCommand(1.020, 1.1)]
    writes = [
        DacWrite(0.990, 1.1),  # the second command's value, but before it: not its write
        DacWrite(1.0003, 1.0),  # the first command's write
        DacWrite(1.0005, 1.05),  # something else
        DacWrite(1.0201, 1.1),  # the second command's write
        DacWrite(1.0300, 1.1),  # a later write of the same value: not the first
    ]
    pairing = pair_writes(commands, writes, tolerance_volts=TOLERANCE_VOLTS)
    assert [write for _, write in pairing.pairs] == [writes[1], writes[3]]
    assert pairing.latencies_s == pytest.approx([0.0003, 0.0001])
    assert pairing.unpaired == 0


def test_a_write_at_the_very_instant_of_the_command_is_its_write_with_zero_latency() -> None:
    pairing = pair_writes(
        [SentCommand(2.5, 0.5)], [DacWrite(2.5, 0.5)], tolerance_volts=TOLERANCE_VOLTS
    )
    assert pairing.latencies_s == [0.0]


def test_a_command_without_its_write_in_the_window_is_unpaired() -> None:
    commands = [SentCommand(1.0, 1.0), SentCommand(2.0, 2.0)]
    writes = [DacWrite(1.2, 1.0), DacWrite(2.001, 2.01)]  # too late; wrong value
    pairing = pair_writes(commands, writes, tolerance_volts=TOLERANCE_VOLTS, window_s=0.1)
    assert pairing.unpaired == 2
    assert pairing.latencies_s == []


def test_values_within_half_a_dac_code_are_the_same_value() -> None:
    code_volts = dac6574.volts_from_code(300)
    pairing = pair_writes(
        [SentCommand(0.0, code_volts)],
        [DacWrite(0.001, code_volts + 1e-12)],
        tolerance_volts=TOLERANCE_VOLTS,
    )
    assert pairing.unpaired == 0


def test_a_can_frame_becomes_the_dac_volts_its_throttle_asks_for() -> None:
    output = ThrottleOutput(DriveConfig(), vref_volts=5.0)
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.3, 0.0, Gear.FORWARD, 7))
    command = can_command(output, 4.2, payload)
    assert command == SentCommand(4.2, dac6574.code_from_volts(1.5).output_volts)


def test_brake_beats_throttle_in_the_expected_volts() -> None:
    output = ThrottleOutput(DriveConfig(), vref_volts=5.0)
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.3, 0.2, Gear.FORWARD, 0))
    command = can_command(output, 0.0, payload)
    assert command is not None
    assert command.throttle_volts == 0.0


def test_a_damaged_can_frame_or_implausible_ibus_frame_is_no_command() -> None:
    output = ThrottleOutput(DriveConfig(), vref_volts=5.0)
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.3, 0.0, Gear.FORWARD, 0))
    damaged = payload[:-1] + bytes([payload[-1] ^ 0xFF])
    assert can_command(output, 0.0, damaged) is None
    mapping = default_sim_config().rc.mapping
    assert rc_command(output, mapping, 0.0, (0,) * 14) is None


def test_the_sweep_changes_every_frame_and_repeats_only_after_all_its_levels() -> None:
    values = [sawtooth_norm(index) for index in range(3 * SWEEP_LEVELS)]
    assert all(a != b for a, b in itertools.pairwise(values))
    assert values[SWEEP_LEVELS] == values[0]
    assert len(set(values)) == SWEEP_LEVELS


def test_span_is_half_open() -> None:
    assert in_span(1.0, (1.0, 2.0))
    assert not in_span(2.0, (1.0, 2.0))


# --- the session on virtual time -----------------------------------------------------------------


class DeafClock(MeteredVirtualClock):
    """A virtual clock that ignores input wake-ups: the controller runs only on its 10 ms ticks,
    as the thesis' polling design did, so every latency is the time to the next tick."""

    def notify_input(self) -> None:
        pass


@pytest.fixture(scope="module")
def virtual_run() -> tuple[RealtimeSession, RealtimeResult]:
    session = RealtimeSession(
        default_sim_config(),
        BenchSettings(phase_s=PHASE_S, settle_s=SETTLE_S),
        MeteredVirtualClock(),
    )
    return session, session.run()


@pytest.fixture(scope="module")
def virtual_session(virtual_run: tuple[RealtimeSession, RealtimeResult]) -> RealtimeSession:
    return virtual_run[0]


@pytest.fixture(scope="module")
def virtual_result(virtual_run: tuple[RealtimeSession, RealtimeResult]) -> RealtimeResult:
    return virtual_run[1]


def test_on_virtual_time_every_command_is_paired_with_a_write_at_its_own_instant(
    virtual_session: RealtimeSession,
) -> None:
    can_commands, rc_commands = virtual_session.commands()
    for commands, span in [
        (can_commands, virtual_session.windows[0].can_span()),
        (rc_commands, virtual_session.windows[0].rc_span()),
    ]:
        chosen = [command for command in commands if in_span(command.completed_s, span)]
        pairing = pair_writes(chosen, virtual_session.writes, tolerance_volts=TOLERANCE_VOLTS)
        assert chosen
        for command, write in pairing.pairs:
            assert write is not None
            assert write.time_s == command.completed_s  # the event-driven write, same instant
            assert write.volts == command.throttle_volts
        volts = [command.throttle_volts for command in chosen]
        assert all(a != b for a, b in itertools.pairwise(volts))


def test_on_virtual_time_both_phases_measure_zero_latency_for_every_frame(
    virtual_result: RealtimeResult,
) -> None:
    half_s = PHASE_S / 2 - SETTLE_S
    for phase in virtual_result.phases:
        can, rc = phase.can_latency, phase.ibus_latency
        assert can.samples == pytest.approx(half_s / 0.020, abs=1)
        assert rc.samples == pytest.approx(half_s / 0.0077, abs=1)
        assert can.unpaired == rc.unpaired == 0
        assert can.max_s == rc.max_s == 0.0
        assert phase.stops == 0


def test_on_virtual_time_the_phases_count_the_100_hz_tasks_and_the_flood_fills_the_bus(
    virtual_result: RealtimeResult,
) -> None:
    nominal, flood = virtual_result.phases
    for phase in (nominal, flood):
        assert [task.name for task in phase.control_tasks] == [  # in order of importance
            "hydrobrake",
            "steering",
            "driving",
        ]
        assert all(task.runs == pytest.approx(PHASE_S * 100, abs=1) for task in phase.tasks[:3])
        assert all(task.overruns == 0 for task in phase.tasks)
    assert nominal.bus_load < 0.2
    assert flood.bus_load > 0.95
    assert virtual_result.peak_rss_bytes > 0


def test_the_authenticated_phase_pairs_every_signed_command_under_flood_with_the_pdus_delay() -> (
    None
):
    """Issue 32: the bench's SecOC phase. On virtual time a command takes effect when its
    cryptographic PDU has crossed the flooded bus, never at the command frame's own instant
    (which would mean nothing was verified): every command paired, none rejected, no STOP."""
    session = RealtimeSession(
        default_sim_config(),
        BenchSettings(phase_s=PHASE_S, settle_s=SETTLE_S),
        MeteredVirtualClock(),
        authenticated=True,
    )
    (phase,) = session.run().phases
    assert phase.name == "secoc_flood"
    assert phase.bus_load > 0.95
    assert session.runtime.can.auth_failures == {}
    can = phase.can_latency
    assert can.samples == pytest.approx((PHASE_S / 2 - SETTLE_S) / 0.020, abs=1)
    assert can.unpaired == 0
    assert can.p50_s is not None
    assert can.max_s is not None
    pdu_bits = 130  # an 8-byte frame with its stuff bits, at most, at 500 kbit/s: 0.26 ms
    assert pdu_bits / 500_000 / 2 < can.p50_s <= can.max_s < 3 * pdu_bits / 500_000
    assert phase.stops == 0


def test_a_controller_that_only_polls_has_the_time_to_its_next_tick_as_latency() -> None:
    session = RealtimeSession(
        default_sim_config(), BenchSettings(phase_s=PHASE_S, settle_s=SETTLE_S), DeafClock()
    )
    session.run()
    can_commands, _ = session.commands()
    span = session.windows[0].can_span()
    chosen = [command for command in can_commands if in_span(command.completed_s, span)]
    pairing = pair_writes(chosen, session.writes, tolerance_volts=TOLERANCE_VOLTS)
    tick_s = 0.010
    expected = [
        math.ceil(command.completed_s / tick_s - 1e-9) * tick_s - command.completed_s
        for command in chosen
    ]
    assert pairing.unpaired == 0
    assert pairing.latencies_s == pytest.approx(expected, abs=1e-9)
    assert max(pairing.latencies_s) > 0.001  # not the trivial zero of the event-driven path


# --- figures, JSON and the table -----------------------------------------------------------------


@pytest.fixture(scope="module")
def bench_result(virtual_result: RealtimeResult) -> BenchResult:
    robot = default_sim_config()
    speedup = measure_speedup(robot, duration_s=2.0)
    rate = measure_verify_rate(robot, campaigns=2, jobs=1, campaign_s=1.0)
    return BenchResult(virtual_result, speedup, rate, machine_info(), {"phase_s": PHASE_S})


PHASE_FIGURES = (
    *(
        f"{path}_latency_{stat}_ms"
        for path in ("can", "ibus")
        for stat in ("p50", "p99", "p999", "max")
    ),
    *(f"{path}_latency_samples" for path in ("can", "ibus")),
    "jitter_p99_ms",
    "jitter_p999_ms",
    "jitter_max_ms",
    "overruns",
    "cpu_percent",
    "process_cpu_percent",
    "bus_load_percent",
    "steal_percent",
)
EXPECTED_KEYS = {f"{phase}_{name}" for phase in ("nominal", "flood") for name in PHASE_FIGURES} | {
    "peak_rss_mb",
    "virtual_speedup",
    "verify_campaigns_per_min",
}
SECOC_KEYS = {
    "secoc_cost_p99_ms",
    "secoc_plain_p50_ms",
    "secoc_plain_p99_ms",
    "secoc_auth_p50_ms",
    "secoc_auth_p99_ms",
    "secoc_wall_cost_p99_ms",
    "secoc_wire_ms",
}


def test_json_has_every_figure_as_a_number_with_its_target(bench_result: BenchResult) -> None:
    document = json.loads(json.dumps(as_json(bench_result)))
    figures = {figure["key"]: figure for figure in document["figures"]}
    assert set(figures) == EXPECTED_KEYS
    for figure in figures.values():
        assert isinstance(figure["value"], float)
        assert set(figure) >= {"label", "unit", "target", "limit", "met", "note", "section"}
    assert figures["nominal_can_latency_p99_ms"]["limit"] == 1.0
    assert figures["virtual_speedup"]["target"] == "≥ 100x"
    assert figures["verify_campaigns_per_min"]["target"] == "≥ 1000 /min"
    assert document["verify_rate"]["campaigns"] == 2
    assert document["targets_missed"] == [
        key for key, figure in figures.items() if figure["met"] is False
    ]
    assert [phase["name"] for phase in document["phases"]] == ["nominal", "flood"]
    assert {"cpu_model", "logical_cpus", "python", "date_utc"} <= set(document["machine"])
    assert document["virtual_time"]["simulated_s"] == 2.0


def test_the_table_shows_every_figure_and_its_verdict(bench_result: BenchResult) -> None:
    console = Console(record=True, width=200)
    console.print(render(bench_result))
    text = console.export_text()
    for figure in all_figures(bench_result):
        assert figure.label in text
    assert "≤ 1 ms" in text
    assert "≤ 80 MB" in text


def test_piped_the_table_keeps_every_row_on_one_line(
    bench_result: BenchResult, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 32, defect 10: `bywire bench > file` cut or wrapped its rows at 80 columns."""
    monkeypatch.delenv("COLUMNS", raising=False)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        stdout_console().print(render(bench_result))
    lines = out.getvalue().splitlines()
    assert not any("…" in line for line in lines)
    at = 0
    for figure in all_figures(bench_result):  # in the table's order, each on the next rows
        at = next(i for i in range(at, len(lines)) if lines[i].strip().startswith(figure.label))
        row = lines[at]
        assert format_value(figure) in row, row  # the value and the target on the label's line
        assert figure.target in row, row
        at += 1


@pytest.mark.parametrize(
    ("figure", "met", "target"),
    [
        (Figure("a", "s", "latency", 0.5, "ms", 1.0), True, "≤ 1 ms"),
        (Figure("a", "s", "latency", 1.5, "ms", 1.0), False, "≤ 1 ms"),
        (Figure("a", "s", "latency", None, "ms", 1.0), False, "≤ 1 ms"),
        (Figure("b", "s", "speed-up", 25.0, "x", 20.0, at_most=False), True, "≥ 20x"),
        (Figure("b", "s", "speed-up", 15.0, "x", 20.0, at_most=False), False, "≥ 20x"),
        (Figure("c", "s", "overruns", 0.0, "", 0.0), True, "0"),
        (Figure("c", "s", "overruns", 2.0, "", 0.0), False, "0"),
        (Figure("d", "s", "bus load", 99.0, "%"), None, ""),
    ],
)
def test_a_figure_meets_its_target_or_not(figure: Figure, met: bool | None, target: str) -> None:
    assert figure.met is met
    assert figure.target == target


def test_the_summary_names_the_missed_targets(bench_result: BenchResult) -> None:
    line = summary_line(bench_result)
    missed = [figure for figure in all_figures(bench_result) if figure.met is False]
    if missed:
        assert all(figure.label in line for figure in missed)
    else:
        assert "met" in line


# --- machine -------------------------------------------------------------------------------------


def test_cpu_model_comes_from_cpuinfo(tmp_path: Path) -> None:
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nmodel name\t: Example CPU @ 1.2GHz\n", encoding="utf-8")
    assert cpu_model(cpuinfo) == "Example CPU @ 1.2GHz"
    assert cpu_model(tmp_path / "missing")  # falls back to something, never raises


# --- the command ---------------------------------------------------------------------------------


def test_bench_quick_json_runs_end_to_end_and_gives_every_figure(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["bench", "--quick", "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    figures = {figure["key"]: figure for figure in document["figures"]}
    secoc_flood = {f"secoc_flood_{name}" for name in PHASE_FIGURES}  # the authenticated phase
    assert set(figures) == EXPECTED_KEYS | SECOC_KEYS | secoc_flood
    for key, figure in figures.items():
        if figure["value"] is None:
            # A quick phase lasts 1 s: a host stall past the input timeouts stops the robot, and
            # a path may then pair no command at all. Only such a path's figures may be null,
            # and its sample count says why.
            assert "_latency_" in key, key
            path = key[: key.index("_latency_")]
            assert figures[f"{path}_latency_samples"]["value"] == 0.0, key
        else:
            assert isinstance(figure["value"], float), key
    assert figures["secoc_cost_p99_ms"]["target"] == "≤ 0.05 ms"
    assert document["secoc"]["authenticated"]["samples"] == 2000
    assert document["settings"]["quick"] is True
    assert document["settings"]["realtime"] is None  # no --realtime: the process as it was
    assert document["tail"] is None  # no --probe


@pytest.mark.parametrize(
    ("option", "message"),
    [(["--duration", "0"], "--duration"), (["--flood-load", "1.5"], "--flood-load")],
)
def test_bench_refuses_bad_options_with_one_line(
    option: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", *option]) == 2
    assert message in capsys.readouterr().err


def test_every_latency_and_jitter_figure_has_its_p999_and_max_and_says_on_how_many_samples(
    bench_result: BenchResult,
) -> None:
    figures = {figure.key: figure for figure in all_figures(bench_result)}
    for phase in bench_result.realtime.phases:
        for path, summary in (("can", phase.can_latency), ("ibus", phase.ibus_latency)):
            key = f"{phase.name}_{path}_latency"
            assert summary.p999_s is not None
            assert figures[f"{key}_p999_ms"].value == pytest.approx(summary.p999_s * 1000)
            assert figures[f"{key}_samples"].value == summary.samples
            assert f"n={summary.samples}" in figures[f"{key}_p999_ms"].note
        runs = min(task.runs for task in phase.control_tasks)
        jitter = figures[f"{phase.name}_jitter_p999_ms"]
        assert f"n={runs}" in jitter.note
        assert (runs < 1000) == ("p99.9 is the max" in jitter.note)


def test_bench_realtime_applies_the_configurations_settings_and_gives_the_collector_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "robot.toml"
    config.write_text('[realtime]\ngc_freeze = false\ngc_mode = "idle"\n', encoding="utf-8")
    args = ["bench", "--quick", "--json", "--realtime", "--config", str(config)]
    assert main(args) == 0
    captured = capsys.readouterr()
    realtime = json.loads(captured.out)["settings"]["realtime"]
    assert realtime == {"applied": ["gc between passes (>= 2 ms idle)"], "refused": []}
    assert "real-time: applied gc between passes" in captured.err
    assert gc.isenabled()  # the virtual-time course and everything after collect as usual


def test_a_phase_after_one_that_fell_to_stop_still_measures_every_frame() -> None:
    # The host stalls the loop in the nominal phase (here: the RC link is lost for 0.3 s, a
    # latched STOP); the flood phase must re-arm and measure, not watch a robot at rest.
    session = RealtimeSession(
        default_sim_config(),
        BenchSettings(phase_s=PHASE_S, settle_s=SETTLE_S),
        MeteredVirtualClock(),
    )
    clock, rc = session.world.clock, session.world.rc
    lost_s = session.windows[0].half_s + 0.3
    clock.call_at(lost_s, rc.link_lost)
    clock.call_at(lost_s + 0.3, rc.link_restored)
    nominal, flood = session.run().phases
    assert nominal.stops == 1
    assert flood.stops == 0
    assert flood.can_latency.unpaired == flood.ibus_latency.unpaired == 0
    assert flood.can_latency.samples == pytest.approx((PHASE_S / 2 - SETTLE_S) / 0.020, abs=1)


def test_the_peak_memory_is_the_first_sessions_and_the_phases_follow_each_other() -> None:
    """The authenticated session runs beside what the first left resident: its peak is no
    controller's footprint, so the figure stays the first session's."""
    first = RealtimeResult((), 58_000_000)
    later = RealtimeResult((), 76_000_000)
    joined = first.then(later)
    assert joined.peak_rss_bytes == 58_000_000
    assert joined.phases == first.phases + later.phases
